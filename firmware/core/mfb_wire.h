/* The MFB wire protocol, version 5, on the board's side (docs/mfb-protocol.md is the specification;
 * include/peha/mfb/protocol.hpp is the host's C++ side of the same bytes).
 *
 * Freestanding C11: no heap, no libc beyond <stdint.h>, <stddef.h>, <stdbool.h>. Every field is
 * written byte by byte in little-endian order, so the layout depends on neither compiler nor CPU.
 * The MAC is not computed here: the caller passes it in (`mfb_mac_fn`, the HAL's keyed BLAKE2b). */
#ifndef PEHA_FIRMWARE_MFB_WIRE_H
#define PEHA_FIRMWARE_MFB_WIRE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define MFB_MAGIC 0x3142464Du /* 'M','F','B','1' on the wire */
#define MFB_PROTOCOL_VERSION 5u
#define MFB_KEY_SIZE 32u
#define MFB_MAC_SIZE 16u
#define MFB_AD_CHANNELS 16
#define MFB_DA_CHANNELS 8
#define MFB_ENCODER_CHANNELS 8

#define MFB_TYPE_COMMAND 1u
#define MFB_TYPE_STATE 2u
#define MFB_TYPE_HELLO 3u /* host -> board: opens a session (the command's layout, its outputs all zero) */

#define MFB_HEADER_SIZE 16u
#define MFB_CRC_SIZE 4u
#define MFB_TRAILER_SIZE (MFB_CRC_SIZE + MFB_MAC_SIZE)
#define MFB_COMMAND_PAYLOAD_SIZE 34u
#define MFB_STATE_PAYLOAD_SIZE 101u
#define MFB_COMMAND_PACKET_SIZE (MFB_HEADER_SIZE + MFB_COMMAND_PAYLOAD_SIZE + MFB_TRAILER_SIZE) /* 70 */
#define MFB_STATE_PACKET_SIZE (MFB_HEADER_SIZE + MFB_STATE_PAYLOAD_SIZE + MFB_TRAILER_SIZE)       /* 137 */

/* Command flags (byte 41). */
#define MFB_COMMAND_ENABLE 0x01u
#define MFB_COMMAND_OPERATOR_ARM 0x02u
#define MFB_COMMAND_KNOWN_FLAGS (MFB_COMMAND_ENABLE | MFB_COMMAND_OPERATOR_ARM)

/* State status bits (byte 101). */
#define MFB_STATUS_WATCHDOG_TRIPPED 0x01u
#define MFB_STATUS_OUTPUTS_SAFE 0x02u
#define MFB_STATUS_ESTOP 0x04u
#define MFB_STATUS_NO_SESSION 0x08u
#define MFB_STATUS_HOST_LOST 0x10u

/* Why a datagram was rejected; the same values, in the same order of checks, as
 * peha::mfb::ParseError. */
typedef enum mfb_parse_error {
  MFB_PARSE_OK = 0,
  MFB_PARSE_TOO_SHORT,
  MFB_PARSE_TOO_LONG,
  MFB_PARSE_BAD_MAGIC,
  MFB_PARSE_BAD_VERSION,
  MFB_PARSE_WRONG_TYPE,
  MFB_PARSE_BAD_LENGTH,
  MFB_PARSE_BAD_CRC,
  MFB_PARSE_BAD_MAC,
  MFB_PARSE_BAD_FLAGS,
  MFB_PARSE_ZERO_SESSION
} mfb_parse_error;

/* Host -> board: a command, one per control period, or a hello (`type`), which opens a session. */
typedef struct mfb_command {
  uint8_t type;                     /* MFB_TYPE_COMMAND or MFB_TYPE_HELLO */
  uint32_t session_id;              /* the host's nonce of the session */
  uint32_t sequence;
  uint64_t host_time_ns;            /* echoed back for the host's round trip */
  uint16_t da[MFB_DA_CHANNELS];     /* DA codes 0..65535 */
  uint8_t digital_out;              /* line i = bit i */
  uint8_t flags;                    /* MFB_COMMAND_* */
  uint64_t board_nonce;             /* the board's nonce of the session (0 in a hello) */
} mfb_command;

/* Board -> host. */
typedef struct mfb_state {
  uint32_t session_id;
  uint32_t sequence;
  uint32_t ack_sequence;
  uint64_t echo_host_time_ns;
  uint64_t board_time_ns;
  uint16_t ad[MFB_AD_CHANNELS];
  int32_t encoder[MFB_ENCODER_CHANNELS];
  uint8_t digital_in;
  uint8_t status;                   /* MFB_STATUS_* */
  uint64_t board_nonce;             /* the session's board nonce; 0: the board holds no such session */
  uint32_t boot_id;
  uint16_t limit_vented;            /* bit 2 x joint + muscle (0 agonist, 1 antagonist): vented by a board limit */
  uint8_t limit_motor_off;          /* bit joint: motor cut by the board's range */
} mfb_state;

/* Keyed BLAKE2b with a 16-byte output over `data` (the HAL's; never written by hand here). */
typedef void (*mfb_mac_fn)(void* ctx, const uint8_t key[MFB_KEY_SIZE], const uint8_t* data, size_t size,
                           uint8_t out[MFB_MAC_SIZE]);

/* CRC-32C (Castagnoli, reflected 0x82F63B78, init and final XOR 0xFFFFFFFF); check value of
 * "123456789" is 0xE3069283. */
uint32_t mfb_crc32c(const uint8_t* data, size_t size);

/* Serial-number order (RFC 1982): true if `a` comes after `b`. */
static inline bool mfb_sequence_newer(uint32_t a, uint32_t b) {
  const uint32_t d = a - b;
  return d != 0u && d < 0x80000000u;
}

/* Parses one whole datagram as a command or a hello (`out->type`), its MAC checked in constant
 * time; a hello with a nonzero output, flag or nonce is MFB_PARSE_BAD_FLAGS. `out` is written only
 * on MFB_PARSE_OK. */
mfb_parse_error mfb_decode_command(const uint8_t* in, size_t size, const uint8_t key[MFB_KEY_SIZE], mfb_mac_fn mac,
                                   void* mac_ctx, mfb_command* out);

/* Writes `s` as MFB_STATE_PACKET_SIZE bytes (CRC and MAC included) into `out`; returns the bytes
 * written, or 0 if `capacity` is too small. */
size_t mfb_encode_state(const mfb_state* s, const uint8_t key[MFB_KEY_SIZE], mfb_mac_fn mac, void* mac_ctx,
                        uint8_t* out, size_t capacity);

/* Writes a command or a hello (`c->type`, written as it is): the host's side, for the tests and tools. */
size_t mfb_encode_command(const mfb_command* c, const uint8_t key[MFB_KEY_SIZE], mfb_mac_fn mac, void* mac_ctx,
                          uint8_t* out, size_t capacity);

#ifdef __cplusplus
}
#endif

#endif
