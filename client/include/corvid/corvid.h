/* Corvid public API, all of it. See README.md and docs/architecture.md. */
#ifndef CORVID_H
#define CORVID_H
#include "corvid/result.h"
#include "corvid/handle.h"
#include "corvid/types.h"
#include "corvid/command_list.h"
#include "corvid/command_codec.h"
#include "corvid/transfer.h"
#include "corvid/pipeline_registry.h"
#include "corvid/context.h"
#include "corvid/device.h"
#endif
