/* Conformance fixtures: one per backend. The same test bodies run on every
 * fixture, so the mock, Vulkan (lavapipe or NVIDIA) and proxy devices are held
 * to one behaviour. A fixture names its backend, how to create its devices, and
 * how to check it stayed clean (e.g. no validation-layer messages). */
#ifndef CORVID_CONFORMANCE_FIXTURE_H
#define CORVID_CONFORMANCE_FIXTURE_H

#include "corvid/device.h"

typedef struct fixture {
    const char *name;
    const cv_backend *(*backend)(void);
    /* Devices a test may create at once (virtual GPUs on one adapter). */
    uint32_t max_devices;
    /* Messages the backend's validation reported since start (0 = clean). */
    uint32_t (*validation_messages)(void);
    /* Whether dispatches and draws really execute (the mock only validates them). */
    bool executes_shaders;
    /* Proxy fixtures: the backend a node started in this process serves
     * (devices then reach it over gRPC on loopback). NULL for local fixtures. */
    const cv_backend *(*node_backend)(void);
} fixture;

/* The fixture named on the command line (NULL if unknown). */
const fixture *fixture_find(const char *name);
cv_result fixture_device(const fixture *f, cv_context *ctx, uint32_t index, cv_device **out);
/* The endpoint of a proxy fixture's node (started on first use), NULL for local fixtures. */
const char *fixture_endpoint(const fixture *f);
/* Waits until what the fixture runs behind the devices has let go of them (a
 * proxy fixture's node ends a session shortly after its client left), so leak
 * checks count only what is really left. */
void fixture_settle(const fixture *f);
/* Stops what the fixture started (a proxy fixture's node); checks it ended clean. */
void fixture_shutdown(const fixture *f);

#endif
