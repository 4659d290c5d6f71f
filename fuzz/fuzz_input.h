/* The fuzz input format shared by the fuzzer and the seed generator: a session's
 * client messages back to back, each a 2-byte little-endian length and that many
 * bytes (a packed corvid.ClientMessage, or anything the fuzzer made of one). A
 * short or missing length ends the input: the client closed its stream. */
#ifndef CORVID_FUZZ_INPUT_H
#define CORVID_FUZZ_INPUT_H

#define FUZZ_MAX_MESSAGE 65535u

#endif
