/* The node protocol's constants and the conversions both sides share.
 *
 * proto/node.proto defines the messages of a session between a client (the
 * proxy backend, client/src/proxy/) and corvid-node (server/node/). This header
 * holds what both ends must agree on beyond the schema: the protocol version,
 * the method paths (proto/node.proto declares the service; protoc-c generates
 * no gRPC stubs, so the C code calls these paths), the sizes of chunks and
 * messages, and the conversions between Corvid's C structs and their messages.
 * Conversions from messages never trust their input: every field is checked and
 * a bad one is named in the error (CV_ERROR_MALFORMED), so the node can answer a
 * hostile client with a clear message.
 *
 *     Corvid__CreateResource msg;
 *     cv_node_desc_storage storage;
 *     cv_node_desc_to_msg(&desc, id, &msg, &storage);   // client
 *     ...
 *     cv_resource_desc desc;
 *     if (cv_node_desc_from_msg(msg, &desc) != CV_OK) ...  // node */
#ifndef CORVID_NODE_PROTOCOL_H
#define CORVID_NODE_PROTOCOL_H

#include "corvid/context.h"
#include "corvid/device.h"
#include "node.pb-c.h"

/* Version 1: the messages of node.proto as first published. A node serves only
 * its own version; the first exchange (Hello) says which one each side speaks. */
#define CV_NODE_PROTOCOL_VERSION 1u

#define CV_NODE_METHOD_SESSION "/corvid.Node/Session"
#define CV_NODE_METHOD_INFO "/corvid.Node/Info"
#define CV_NODE_METHOD_PEER_PIECE "/corvid.Node/PeerPiece"
#define CV_HEALTH_METHOD_CHECK "/grpc.health.v1.Health/Check"
#define CV_HEALTH_METHOD_WATCH "/grpc.health.v1.Health/Watch"

/* Bulk data moves in pieces of this size: blob chunks, inline writes and read
 * results (256 KiB to 1 MiB messages move fastest through gRPC). */
#define CV_NODE_CHUNK_BYTES (1u << 20)
/* The largest message either side accepts: a chunk plus its envelope, with room. */
#define CV_NODE_MAX_MESSAGE_BYTES (4u << 20)
/* Buffer writes of at least this many bytes are content-addressed (hashed,
 * sent once per node cache); smaller ones travel inline. */
#define CV_NODE_BLOB_MIN_BYTES (256u << 10)
#define CV_SHA256_BYTES 32u
/* A session's capability for node-to-node transfers (HelloReply.session_key). */
#define CV_NODE_SESSION_KEY_BYTES 16u
/* The largest node-to-node transfer, before and after compression. */
#define CV_NODE_PEER_MAX_BYTES (256ull << 20)
/* What one ClientMessage of `bytes` bytes may decode to (protobuf-c structures) on the node: more ends the
 * stream, so a small hostile message cannot make the node allocate gigabytes; every legitimate message fits
 * well inside. An encoded CommandList has the same budget (command_codec.c). */
#define CV_NODE_UNPACK_BUDGET_BASE_BYTES (64u << 10)
#define CV_NODE_UNPACK_BUDGET(bytes) (2u * (size_t)(bytes) + CV_NODE_UNPACK_BUDGET_BASE_BYTES)
/* Hashes in one BlobQuery, at most. */
#define CV_NODE_MAX_BLOB_QUERY 4096u
/* Encoder streams (OpenEncoder) one session holds open at most, the largest side
 * of their frames and the most pixels (4096x2160): what a session may make the
 * node allocate for them. */
#define CV_NODE_MAX_ENCODER_STREAMS 4u
#define CV_NODE_MAX_ENCODE_SIDE 8192u
#define CV_NODE_MAX_ENCODE_PIXELS 8847360u

/* A PushTransfer / AwaitTransfer region checked against the resource it names
 * (desc): a texture rect (width, height not 0) or a buffer range (size not 0,
 * width = height = 0). *bytes gets its size in bytes (0 on failure).
 * CV_ERROR_OUT_OF_RANGE / CV_ERROR_MALFORMED name `what`, the region and the
 * resource. */
cv_result cv_node_check_region(const cv_resource_desc *desc, uint32_t x, uint32_t y, uint32_t width, uint32_t height,
                               uint64_t offset, uint64_t size, const char *what, uint64_t *bytes);

/* Storage the pointers of a filled Corvid__CreateResource refer to. */
typedef struct cv_node_desc_storage {
    char label[CV_LABEL_MAX];
    char pipeline[CV_LABEL_MAX];
    Corvid__BufferDesc buffer;
    Corvid__TextureDesc texture;
    Corvid__SamplerDesc sampler;
    Corvid__PipelineDesc pipeline_desc;
    Corvid__AccelDesc accel;
} cv_node_desc_storage;

/* Fills msg (initialised here) for handle `id` described by desc (NULL desc: a
 * command list). */
void cv_node_desc_to_msg(uint64_t id, const cv_resource_desc *desc, Corvid__CreateResource *msg,
                         cv_node_desc_storage *storage);
/* The description in msg, checked for form (type present and matching the
 * handle's type tag, label and name fit). Values are checked again by the
 * context's create calls. CV_ERROR_MALFORMED names the field. */
cv_result cv_node_desc_from_msg(const Corvid__CreateResource *msg, cv_resource_desc *out);

/* Device info both ways. The message's strings point into `info`. */
typedef struct cv_node_info_storage {
    uint32_t max_dispatch[3];
} cv_node_info_storage;
void cv_node_info_to_msg(const cv_device_info *info, const char *label, Corvid__DeviceInfo *msg,
                         cv_node_info_storage *storage);
void cv_node_info_from_msg(const Corvid__DeviceInfo *msg, cv_device_info *out);

/* Encode parameters both ways (a NULL message: every default). */
void cv_node_encode_params_to_msg(const cv_encode_params *params, Corvid__EncodeParams *msg);
void cv_node_encode_params_from_msg(const Corvid__EncodeParams *msg, cv_encode_params *out);

/* A bytes field that must hold exactly one SHA-256. */
cv_result cv_node_check_sha(ProtobufCBinaryData b, const char *field);

/* Packs a message into a malloc'd buffer (caller frees). */
cv_result cv_node_pack_client(const Corvid__ClientMessage *m, uint8_t **out, size_t *size);
cv_result cv_node_pack_node(const Corvid__NodeMessage *m, uint8_t **out, size_t *size);

#endif
