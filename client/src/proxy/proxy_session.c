/* A proxy device's session with its node: connect and hello, sending,
 * request/answer, and the receiver thread (proxy_session.h). */
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "corvid/clock.h"
#include "corvid/parse.h"
#include "proxy_options.h"
#include "proxy_session.h"

static void send_resume(proxy_device *p, uint64_t failure);

/* Marks the session unusable (lock held) and wakes every waiter. */
static void set_dead(proxy_device *p, cv_result code, const char *why) {
    if (p->dead == CV_OK) {
        p->dead = code;
        snprintf(p->dead_message, sizeof(p->dead_message), "%s", why);
    }
    pthread_cond_broadcast(&p->cond);
}

cv_result proxy_health(proxy_device *p) {
    pthread_mutex_lock(&p->lock);
    cv_result r = CV_OK;
    if (p->dead != CV_OK) {
        r = cv_error(p->dead, "node '%s': %s", p->endpoint, p->dead_message);
        p->loss_reported = true; /* the caller learns it now */
    } else if (p->async_error != CV_OK)
        r = cv_error(p->async_error, "node '%s' refused an earlier request: %s", p->endpoint, p->async_message);
    pthread_mutex_unlock(&p->lock);
    return r;
}

cv_result proxy_send(proxy_device *p, Corvid__ClientMessage *m) {
    if (p->before_send)
        p->before_send(p);
    return proxy_send_now(p, m);
}

cv_result proxy_send_now(proxy_device *p, Corvid__ClientMessage *m) {
    cv_result r = proxy_health(p);
    if (r != CV_OK)
        return r;
    if (!m->seq)
        m->seq = atomic_fetch_add(&p->next_seq, 1) + 1;
    uint8_t *buf;
    size_t size;
    r = cv_node_pack_client(m, &buf, &size);
    if (r != CV_OK)
        return r;
    r = cv_rpc_stream_send_owned(p->stream, buf, size);
    pthread_mutex_lock(&p->lock);
    if (r == CV_OK) {
        p->stats.messages_sent++;
        p->stats.bytes_sent += size;
    } else {
        set_dead(p, CV_ERROR_CONNECTION, cv_last_error());
    }
    pthread_mutex_unlock(&p->lock);
    return r == CV_OK ? CV_OK : cv_error(CV_ERROR_CONNECTION, "node '%s': %s", p->endpoint, p->dead_message);
}

/* Registers the request in `slot` (waiting until the slot is free: the encoded reads' slot is shared by a
 * device's streams) and sends it. On failure the slot is free again and *pending says why. */
static cv_result request_send(proxy_device *p, Corvid__ClientMessage *m, proxy_pending *slot,
                              proxy_pending *pending) {
    pthread_mutex_lock(&p->lock);
    while (slot->seq && p->dead == CV_OK)
        pthread_cond_wait(&p->cond, &p->lock);
    if (slot->seq) { /* the session died while another request held the slot */
        cv_result r = cv_error(p->dead, "node '%s': %s", p->endpoint, p->dead_message);
        pthread_mutex_unlock(&p->lock);
        return r;
    }
    m->seq = atomic_fetch_add(&p->next_seq, 1) + 1;
    pending->seq = m->seq;
    pending->done = false;
    pending->result = CV_OK;
    pending->message[0] = '\0';
    *slot = *pending;
    p->stats.round_trips++;
    pthread_mutex_unlock(&p->lock);
    cv_result r = proxy_send(p, m);
    if (r != CV_OK) {
        pthread_mutex_lock(&p->lock);
        *pending = *slot;
        *slot = (proxy_pending){ 0 };
        pthread_cond_broadcast(&p->cond);
        pthread_mutex_unlock(&p->lock);
    }
    return r;
}

/* Waits for the answer in `slot` (sent by request_send), copies it to *pending and frees the slot. */
static cv_result request_wait(proxy_device *p, proxy_pending *slot, proxy_pending *pending) {
    pthread_mutex_lock(&p->lock);
    cv_result r = CV_OK;
    uint64_t seq = slot->seq, deadline = cv_deadline_after_ms(p->timeout_ms);
    while (!slot->done && p->dead == CV_OK)
        if (cv_cond_wait_until(&p->cond, &p->lock, deadline) != 0)
            break;
    if (slot->done)
        r = slot->result == CV_OK ? CV_OK : cv_error(slot->result, "node '%s': %s", p->endpoint, slot->message);
    else if (p->dead != CV_OK)
        r = cv_error(p->dead, "node '%s': %s", p->endpoint, p->dead_message);
    else {
        /* No answer in time: the session cannot be trusted to match any more. */
        set_dead(p, CV_ERROR_TIMEOUT, "no answer within the request timeout");
        r = cv_error(CV_ERROR_TIMEOUT, "node '%s': no answer to request %" PRIu64 " within %u ms", p->endpoint, seq,
                     p->timeout_ms);
    }
    *pending = *slot;
    if (slot->encoded) { /* the frame leaves with its request: the next read's pieces start a new one */
        pending->frame = *slot->encoded;
        memset(slot->encoded, 0, sizeof(*slot->encoded));
    }
    *slot = (proxy_pending){ 0 };
    pthread_cond_broadcast(&p->cond);
    uint64_t failure = r != CV_OK ? pending->transfer_failure : 0;
    if (failure > p->resumed) {
        p->resumed = failure; /* the caller learns of it now */
        if (p->soft_failure == failure)
            p->soft_failure = 0;
    } else {
        failure = 0;
    }
    pthread_mutex_unlock(&p->lock);
    if (failure) {
        char why[CV_ERROR_MESSAGE_MAX];
        snprintf(why, sizeof(why), "%s", cv_last_error());
        send_resume(p, failure);
        r = cv_error(r, "%s", why);
    }
    return r;
}

cv_result proxy_request(proxy_device *p, Corvid__ClientMessage *m, proxy_pending *pending) {
    cv_result r = request_send(p, m, &p->pending, pending);
    return r == CV_OK ? request_wait(p, &p->pending, pending) : r;
}

cv_result proxy_request_start(proxy_device *p, Corvid__ClientMessage *m, proxy_pending *pending) {
    return request_send(p, m, &p->encode_pending, pending);
}

cv_result proxy_request_finish(proxy_device *p, proxy_pending *pending) {
    return request_wait(p, &p->encode_pending, pending);
}

/* ---- receiving ------------------------------------------------------------- */

void proxy_note_failure(proxy_device *p, uint64_t failure, uint64_t seq, uint64_t ticket, cv_result result,
                        const char *message) {
    p->stats.transfer_failures += failure > p->resumed && failure != p->soft_failure;
    if (failure <= p->resumed || p->soft_failure)
        return; /* of a frame already reported, or one is waiting to be */
    for (uint32_t i = 0; i < PROXY_AWAITS; i++)
        if (p->awaits[i].source && p->awaits[i].given_up && p->awaits[i].seq == seq) {
            p->resumed = failure; /* started by an await the client gave up: that frame was reported */
            return;
        }
    p->soft_seq = seq;
    p->soft_failure = failure;
    p->soft_ticket = ticket;
    p->soft_result = result != CV_OK ? result : CV_ERROR_CONNECTION;
    snprintf(p->soft_message, sizeof(p->soft_message), "%s", message ? message : "");
}

static void send_resume(proxy_device *p, uint64_t failure) {
    Corvid__ResumeAfterFailure resume = CORVID__RESUME_AFTER_FAILURE__INIT;
    resume.failure = failure;
    Corvid__ClientMessage m = CORVID__CLIENT_MESSAGE__INIT;
    m.msg_case = CORVID__CLIENT_MESSAGE__MSG_RESUME;
    m.resume = &resume;
    proxy_send_now(p, &m); /* a dead session fails every later call anyway */
}

cv_result proxy_report_failure(proxy_device *p, uint64_t ticket) {
    pthread_mutex_lock(&p->lock);
    uint64_t failure = p->soft_failure;
    cv_result r = CV_OK;
    if (failure && p->soft_ticket <= ticket) {
        r = cv_error(p->soft_result, "node '%s': %s", p->endpoint, p->soft_message);
        p->resumed = failure;
        p->soft_failure = 0;
    }
    pthread_mutex_unlock(&p->lock);
    if (r != CV_OK) {
        char why[CV_ERROR_MESSAGE_MAX];
        snprintf(why, sizeof(why), "%s", cv_last_error());
        send_resume(p, failure);
        r = cv_error(r, "%s", why);
    }
    return r;
}

static void on_reply(proxy_device *p, uint64_t seq, const Corvid__Reply *reply) {
    proxy_pending *slot = p->pending.seq == seq          ? &p->pending
                          : p->encode_pending.seq == seq ? &p->encode_pending
                                                         : NULL;
    if (slot) {
        slot->transfer_failure = reply->transfer_failure;
        slot->result = (cv_result)reply->result;
        snprintf(slot->message, sizeof(slot->message), "%s", reply->message ? reply->message : "");
        slot->done = true;
    } else if (reply->transfer_failure) {
        proxy_note_failure(p, reply->transfer_failure, seq, 0, (cv_result)reply->result, reply->message);
    } else if (reply->result != CV_OK && p->async_error == CV_OK) {
        p->async_error = (cv_result)reply->result;
        snprintf(p->async_message, sizeof(p->async_message), "request %" PRIu64 ": %s", seq,
                 reply->message ? reply->message : "");
    }
}

static void on_read_data(proxy_device *p, uint64_t seq, const Corvid__ReadData *d) {
    proxy_pending *w = &p->pending;
    if (w->seq != seq || !w->read_into) {
        set_dead(p, CV_ERROR_MALFORMED, "read data for no read in flight");
        return;
    }
    if (d->offset != w->read_received || d->data.len > w->read_size - w->read_received) {
        set_dead(p, CV_ERROR_MALFORMED, "read data out of order or past the end");
        return;
    }
    memcpy(w->read_into + d->offset, d->data.data, d->data.len);
    w->read_received += d->data.len;
    if (d->last) {
        w->result = w->read_received == w->read_size ? CV_OK : CV_ERROR_MALFORMED;
        if (w->result != CV_OK)
            snprintf(w->message, sizeof(w->message), "read ended after %" PRIu64 " of %" PRIu64 " bytes",
                     w->read_received, w->read_size);
        w->done = true;
    }
}

/* A piece of an encoded frame (ReadEncoded): the first says the frame's size and what it is. */
static void on_encoded_frame(proxy_device *p, uint64_t seq, const Corvid__EncodedFrame *f) {
    proxy_pending *w = &p->encode_pending;
    if (w->seq != seq || !w->encoded) {
        set_dead(p, CV_ERROR_MALFORMED, "an encoded frame for no encoded read in flight");
        return;
    }
    cv_encoded *e = w->encoded;
    if (!e->data) {
        if (f->offset != 0 || f->size > w->encoded_max) {
            set_dead(p, CV_ERROR_MALFORMED, "an encoded frame that does not start at 0 or is larger than allowed");
            return;
        }
        e->data = malloc(f->size ? f->size : 1);
        if (!e->data) {
            set_dead(p, CV_ERROR_OUT_OF_MEMORY, "no memory for an encoded frame");
            return;
        }
        e->size = f->size;
        e->codec = (cv_codec)f->codec;
        e->width = f->width;
        e->height = f->height;
        e->keyframe = f->keyframe;
        e->read_ms = f->read_ms;
        e->encode_ms = f->encode_ms;
    }
    if (f->offset != w->encoded_received || f->data.len > e->size - w->encoded_received) {
        set_dead(p, CV_ERROR_MALFORMED, "encoded frame data out of order or past the end");
        return;
    }
    if (f->data.len)
        memcpy(e->data + f->offset, f->data.data, f->data.len);
    w->encoded_received += f->data.len;
    if (f->last) {
        w->result = w->encoded_received == e->size ? CV_OK : CV_ERROR_MALFORMED;
        if (w->result != CV_OK)
            snprintf(w->message, sizeof(w->message), "encoded frame ended after %" PRIu64 " of %zu bytes",
                     w->encoded_received, e->size);
        w->done = true;
    }
}

static void on_completed(proxy_device *p, const Corvid__Completed *c) {
    if (c->ticket <= p->completed) {
        set_dead(p, CV_ERROR_MALFORMED, "a ticket completed twice or out of order");
        return;
    }
    proxy_inflight *slot = &p->inflight[c->ticket % PROXY_INFLIGHT];
    if (slot->ticket == c->ticket && slot->list && c->result == CV_OK) {
        proxy_list *l = slot->list;
        l->timing_count = 0;
        for (size_t i = 0; i < c->n_timings && i < PROXY_MAX_TIMINGS; i++) {
            cv_pass_timing *t = &l->timings[l->timing_count++];
            snprintf(t->label, sizeof(t->label), "%s", c->timings[i]->label ? c->timings[i]->label : "");
            t->start_ms = c->timings[i]->start_ms;
            t->duration_ms = c->timings[i]->duration_ms;
            t->host_ms = 0.0; /* the node's clock is not this process's */
        }
    }
    slot->ticket = 0;
    slot->list = NULL;
    if (c->transfer_failure) {
        proxy_note_failure(p, c->transfer_failure, 0, c->ticket, (cv_result)c->result, c->message);
    } else if (c->refused && c->result != CV_OK) {
        if (!p->refused_ticket) {
            p->refused_ticket = c->ticket;
            p->refused_result = (cv_result)c->result;
            snprintf(p->refused_message, sizeof(p->refused_message), "%s", c->message ? c->message : "");
        }
    } else if (c->result != CV_OK && p->async_error == CV_OK) {
        p->async_error = (cv_result)c->result;
        snprintf(p->async_message, sizeof(p->async_message), "submission %" PRIu64 ": %s", c->ticket,
                 c->message ? c->message : "");
    }
    p->completed = c->ticket;
}

static void on_message(proxy_device *p, const Corvid__NodeMessage *m) {
    /* A session is dead once a send failed or a request timed out, while messages received before
     * may still be queued: the caller has been told, and what they name may be freed (lists of
     * tickets the dead session reports finished). */
    if (p->dead != CV_OK)
        return;
    switch (m->msg_case) {
    case CORVID__NODE_MESSAGE__MSG_HELLO:
        if (p->pending.seq == m->seq && p->pending.hello_info && m->hello->device) {
            cv_node_info_from_msg(m->hello->device, p->pending.hello_info);
            p->pending.session_id = m->hello->session_id;
            if (m->hello->quotas) {
                p->pending.quota_inflight = m->hello->quotas->inflight;
                p->pending.quota_upload = m->hello->quotas->upload_bytes;
                p->pending.max_blob = m->hello->quotas->max_blob_bytes;
            }
            if (m->hello->session_key.len == CV_NODE_SESSION_KEY_BYTES) {
                memcpy(p->pending.session_key, m->hello->session_key.data, CV_NODE_SESSION_KEY_BYTES);
                p->pending.has_session_key = true;
            }
            p->pending.done = true;
        }
        break;
    case CORVID__NODE_MESSAGE__MSG_REPLY: on_reply(p, m->seq, m->reply); break;
    case CORVID__NODE_MESSAGE__MSG_BLOB_STATUS:
        if (p->pending.seq == m->seq && p->pending.present) {
            if (m->blob_status->n_present != p->pending.present_count) {
                set_dead(p, CV_ERROR_MALFORMED, "blob status of the wrong length");
                break;
            }
            for (size_t i = 0; i < m->blob_status->n_present; i++)
                p->pending.present[i] = m->blob_status->present[i];
            p->pending.done = true;
        }
        break;
    case CORVID__NODE_MESSAGE__MSG_READ_DATA: on_read_data(p, m->seq, m->read_data); break;
    case CORVID__NODE_MESSAGE__MSG_COMPLETED: on_completed(p, m->completed); break;
    case CORVID__NODE_MESSAGE__MSG_ENCODED_FRAME: on_encoded_frame(p, m->seq, m->encoded_frame); break;
    default: set_dead(p, CV_ERROR_MALFORMED, "an unknown message from the node"); break;
    }
    pthread_cond_broadcast(&p->cond);
}

static void *receiver_main(void *arg) {
    proxy_device *p = arg;
    for (;;) {
        uint8_t *data = NULL;
        size_t size = 0;
        cv_result r = cv_rpc_stream_recv(p->stream, UINT32_MAX, &data, &size);
        if (r != CV_OK || !data) {
            char status[400];
            int code = cv_rpc_stream_status(p->stream, status, sizeof(status));
            char why[512];
            if (r != CV_OK)
                snprintf(why, sizeof(why), "connection lost: %s", cv_last_error());
            else
                snprintf(why, sizeof(why), "the node ended the session (status %d%s%s)", code, status[0] ? ": " : "",
                         status);
            pthread_mutex_lock(&p->lock);
            set_dead(p, CV_ERROR_CONNECTION, why);
            pthread_mutex_unlock(&p->lock);
            return NULL;
        }
        Corvid__NodeMessage *m = corvid__node_message__unpack(NULL, size, data);
        free(data);
        pthread_mutex_lock(&p->lock);
        p->stats.bytes_received += size;
        if (m)
            on_message(p, m);
        else
            set_dead(p, CV_ERROR_MALFORMED, "a message from the node is not a corvid.NodeMessage");
        pthread_mutex_unlock(&p->lock);
        if (m)
            corvid__node_message__free_unpacked(m, NULL);
    }
}

/* ---- open / close ----------------------------------------------------------- */

cv_result proxy_session_open(proxy_device *p, cv_device_info *info) {
    proxy_settings *s = malloc(sizeof(*s));
    if (!s)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "proxy: settings");
    proxy_settings_get(s);
    cv_rpc_client_config cc;
    proxy_client_config(s, &cc);
    cv_result r = cv_rpc_client_create(p->endpoint, &cc, &p->client);
    memset(s->token, 0, sizeof(s->token));
    free(s);
    if (r != CV_OK) /* this client's settings (token and TLS files): creating connects nothing yet */
        return cv_error(r, "node '%s': %s", p->endpoint, cv_last_error());
    if (r == CV_OK)
        r = cv_rpc_client_open(p->client, CV_NODE_METHOD_SESSION, NULL, 0, &p->stream);
    if (r == CV_OK) {
        if (pthread_create(&p->receiver, NULL, receiver_main, p) == 0)
            p->receiver_started = true;
        else
            r = cv_error(CV_ERROR_OUT_OF_MEMORY, "proxy: cannot start the receiver thread");
    }
    if (r != CV_OK)
        return cv_error(CV_ERROR_CONNECTION, "node '%s': %s", p->endpoint, cv_last_error());
    Corvid__Hello hello = CORVID__HELLO__INIT;
    hello.protocol_version = CV_NODE_PROTOCOL_VERSION;
    hello.client_name = "corvid proxy";
    hello.device = p->remote_device;
    Corvid__ClientMessage m = CORVID__CLIENT_MESSAGE__INIT;
    m.msg_case = CORVID__CLIENT_MESSAGE__MSG_HELLO;
    m.hello = &hello;
    proxy_pending pending = { .hello_info = info };
    r = proxy_request(p, &m, &pending);
    if (r != CV_OK)
        return r;
    memcpy(p->session_key, pending.session_key, sizeof(p->session_key));
    p->has_session_key = pending.has_session_key;
    p->quota_inflight = pending.quota_inflight;
    p->quota_upload = pending.quota_upload;
    p->max_blob = pending.max_blob;
    snprintf(info->backend, sizeof(info->backend), "proxy");
    info->adapter_index = p->remote_device;
    return CV_OK;
}

void proxy_session_close(proxy_device *p) {
    if (p->stream) {
        /* Half-close: the node finishes what it was sent, then ends the stream. */
        cv_rpc_stream_close_send(p->stream);
        if (p->receiver_started) {
            pthread_mutex_lock(&p->lock);
            uint64_t deadline = cv_deadline_after_ms(p->timeout_ms);
            while (p->dead == CV_OK)
                if (cv_cond_wait_until(&p->cond, &p->lock, deadline) != 0)
                    break;
            pthread_mutex_unlock(&p->lock);
        }
        cv_rpc_stream_cancel(p->stream);
        if (p->receiver_started)
            pthread_join(p->receiver, NULL);
        cv_rpc_stream_destroy(p->stream);
        p->stream = NULL;
    }
    if (p->client)
        cv_rpc_client_destroy(p->client);
    p->client = NULL;
}
