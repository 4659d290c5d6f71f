/* Command lists on the wire: the protobuf encoding of proto/corvid.proto's
 * CommandList.
 *
 * Encoding walks a list that ended without error and writes one Command
 * message per recorded command. Decoding never trusts its input: it parses
 * each Command and replays it through the same cv_cmd_<name> recording calls
 * an application uses, so a decoded list has passed exactly the checks of a
 * recorded one (queue types, handle type tags, sizes, render-pass and marker
 * nesting), plus the wire's own checks (well-formed protobuf, a known command
 * in every Command, queue numbers in range, handle tags that exist).
 *
 * Every value travels bit for bit except a float -0.0, which arrives as +0.0:
 * proto3 leaves out a float equal to its default 0, and protobuf-c compares
 * by value.
 *
 * Both directions are generated from CV_COMMAND_TABLE, so a command added to
 * the table is encoded and decoded with no change here (tests/codec checks the
 * .proto declares it). */
#ifndef CORVID_COMMAND_CODEC_H
#define CORVID_COMMAND_CODEC_H

#include <stddef.h>
#include <stdint.h>

#include "corvid/command_list.h"

/* Largest encoded list either direction accepts. Lists carry at most
 * CV_MAX_LIST_DATA bytes of side data, so this leaves room for the commands. */
#define CV_MAX_ENCODED_LIST (64u << 20)

/* Encodes a list that ended successfully (ended_ok) into a malloc'd buffer the
 * caller frees with free(). An empty list encodes to zero bytes (*out is still
 * a valid pointer to free). Fails with CV_ERROR_BAD_STATE for a list that is
 * recording or ended with an error, CV_ERROR_LIMIT_EXCEEDED above
 * CV_MAX_ENCODED_LIST. */
cv_result cv_command_list_encode(const cv_command_list *list, uint8_t **out, size_t *out_size);

/* Decodes `size` bytes into `list`, which the caller initialised with
 * cv_command_list_init (it may hold an earlier recording, which is replaced).
 * On success the list has ended and may be compiled and submitted; its id is
 * kept and its version bumped as by cv_command_list_begin. On failure the list
 * is unchanged and the result is CV_ERROR_MALFORMED (not protobuf, an empty or
 * unknown command, a queue number out of range), CV_ERROR_LIMIT_EXCEEDED
 * (input above CV_MAX_ENCODED_LIST, too many bindings), CV_ERROR_INVALID_HANDLE
 * (a handle with a tag no resource type has), or whatever recording the same
 * command would have returned; cv_last_error() names the command index. */
cv_result cv_command_list_decode(const uint8_t *data, size_t size, cv_command_list *list);

#endif
