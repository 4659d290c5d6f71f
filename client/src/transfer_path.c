/* The choice of transfer path (transfer.h): the mode in force (the API's, else
 * AUTO) resolved against what the two devices offer (backend.h, cv_link_caps). */
#include <stdatomic.h>
#include <stdio.h>
#include <string.h>

#include "corvid/transfer.h"

#include "device_internal.h"
#include "transfer_link.h"
#include "transfer_peer.h"

static const char *const names[CV_TRANSFER_PATH_COUNT] = {
    "auto", "staged", "host-import", "shared", "peer", "device"
};

/* process-wide: a program's override for comparisons and benchmarks (corvid-render's CORVID_TRANSFER_PATH),
 * meant for every transfer of the process, most of them made deep inside the render graph and the node's
 * sessions, which take no transfer settings of their own. AUTO: none. */
static _Atomic int mode_forced = CV_TRANSFER_AUTO;

const char *cv_transfer_path_name(cv_transfer_path path) {
    return (unsigned)path < CV_TRANSFER_PATH_COUNT ? names[path] : "unknown";
}

cv_result cv_transfer_path_parse(const char *name, cv_transfer_path *out) {
    for (int i = 0; name && out && i < CV_TRANSFER_PATH_COUNT; i++)
        if (strcmp(name, names[i]) == 0) {
            *out = (cv_transfer_path)i;
            return CV_OK;
        }
    return cv_error(CV_ERROR_INVALID_ARGUMENT,
                    "transfer path '%s' is not one of auto, staged, host-import, shared, peer, device",
                    name ? name : "(null)");
}

cv_result cv_transfer_set_path(cv_transfer_path path) {
    if ((unsigned)path >= CV_TRANSFER_PATH_COUNT)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_transfer_set_path: no path %d", (int)path);
    atomic_store(&mode_forced, (int)path);
    return CV_OK;
}

void cv_transfer_clear_path(void) { atomic_store(&mode_forced, (int)CV_TRANSFER_AUTO); }

cv_result cv_transfer_mode(cv_transfer_path *out) {
    *out = (cv_transfer_path)atomic_load(&mode_forced);
    return CV_OK;
}

/* Whether the pair can take `path` (DEVICE, SHARED or HOST_IMPORT); if not, why, in `why`. */
static bool pair_can(cv_device *src, cv_device *dst, cv_transfer_path path, char *why, size_t cap) {
    if (path == CV_TRANSFER_DEVICE) {
        bool ok = cv_device_link_same_group(src, dst);
        if (!ok)
            snprintf(why, cap,
                     "they are not two instances of one shared device (Vulkan: virtual GPUs of one adapter with "
                     "CORVID_VGPU_DEVICE=shared)");
        return ok;
    }
    cv_link_caps a, b;
    bool la = cv_device_link_caps(src, &a), lb = cv_device_link_caps(dst, &b);
    cv_device *who = !la ? src : dst;
    if (!la || !lb) {
        snprintf(why, cap, "device '%s' (%s backend) has no device-side transfers", cv_device_label(who),
                 cv_device_get_info(who)->backend);
        return false;
    }
    if (strcmp(cv_device_get_info(src)->backend, cv_device_get_info(dst)->backend) != 0) {
        snprintf(why, cap, "the devices are on different backends (%s, %s)", cv_device_get_info(src)->backend,
                 cv_device_get_info(dst)->backend);
        return false;
    }
    if (path == CV_TRANSFER_SHARED) {
        if (!a.shared_memory || !b.shared_memory) {
            snprintf(why, cap, "device '%s' lacks %s", cv_device_label(!a.shared_memory ? src : dst),
                     !a.shared_memory ? a.shared_missing : b.shared_missing);
            return false;
        }
        if (memcmp(a.driver_uuid, b.driver_uuid, 16) != 0 || memcmp(a.device_uuid, b.device_uuid, 16) != 0) {
            snprintf(why, cap,
                     "they are different adapters or drivers (driverUUID/deviceUUID differ), and memory "
                     "is shared only within one (VK_KHR_external_memory_fd, opaque fd)");
            return false;
        }
        return true;
    }
    if (!a.host_import || !b.host_import) {
        snprintf(why, cap, "device '%s' lacks %s", cv_device_label(!a.host_import ? src : dst),
                 !a.host_import ? a.host_missing : b.host_missing);
        return false;
    }
    return true;
}

cv_result cv_transfer_choose_path(cv_device *src, cv_device *dst, cv_transfer_path *out) {
    if (!src || !dst || !out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_transfer_choose_path: NULL argument");
    cv_transfer_path mode;
    cv_result r = cv_transfer_mode(&mode);
    if (r != CV_OK)
        return r;
    char why[256];
    if (mode == CV_TRANSFER_PEER || (mode == CV_TRANSFER_AUTO && cv_transfer_peer_pair(src, dst))) {
        *out = CV_TRANSFER_PEER;
        if (!cv_transfer_peer_pair(src, dst))
            return cv_error(CV_ERROR_UNSUPPORTED,
                            "transfer from device '%s' to device '%s': the peer path is forced but they are not "
                            "two proxy devices on nodes that send to each other",
                            cv_device_label(src), cv_device_label(dst));
        return CV_OK;
    }
    if (mode == CV_TRANSFER_AUTO) {
        /* One copy between instances of one device first: on the H200
         * (1920x1080, 64 frames, docs/transfers.md) `device` takes 4.3 ms a
         * frame on 2 virtual GPUs and 4.5 on 4, the two ring copies of
         * `shared` 4.8 and 5.3 (one device: 4.4). Then shared memory. */
        *out = pair_can(src, dst, CV_TRANSFER_DEVICE, why, sizeof(why))        ? CV_TRANSFER_DEVICE
               : pair_can(src, dst, CV_TRANSFER_SHARED, why, sizeof(why))      ? CV_TRANSFER_SHARED
               : pair_can(src, dst, CV_TRANSFER_HOST_IMPORT, why, sizeof(why)) ? CV_TRANSFER_HOST_IMPORT
                                                                               : CV_TRANSFER_STAGED;
        return CV_OK;
    }
    if (mode != CV_TRANSFER_STAGED && !pair_can(src, dst, mode, why, sizeof(why)))
        return cv_error(CV_ERROR_UNSUPPORTED,
                        "transfer from device '%s' to device '%s': the %s path is forced but %s",
                        cv_device_label(src), cv_device_label(dst), cv_transfer_path_name(mode), why);
    *out = mode;
    return CV_OK;
}
