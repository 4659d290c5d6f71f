/* The proxy device's encoder streams (backend.h: encoder_open / encoder_read /
 * encoder_close): the node reads a texture of its device and encodes it there,
 * so only the encoded frame crosses the link (node.proto: OpenEncoder,
 * ReadEncoded, CloseEncoder, EncodedFrame). */
#ifndef CORVID_PROXY_ENCODE_H
#define CORVID_PROXY_ENCODE_H

#include "proxy_internal.h"

cv_result proxy_encoder_open(cv_backend_device *p, uint32_t stream, cv_codec codec, uint32_t width, uint32_t height);
cv_result proxy_encoder_send(cv_backend_device *p, uint32_t stream, void *tex, const cv_texture_desc *desc,
                             cv_rect rect, const cv_encode_params *params);
cv_result proxy_encoder_receive(cv_backend_device *p, uint32_t stream, cv_encoded *out);
void proxy_encoder_close(cv_backend_device *p, uint32_t stream);

#endif
