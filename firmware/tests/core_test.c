/* The board core's unit tests: one source, run on the development machine (ctest firmware.core)
 * and on an emulated Cortex-M7 (ctest firmware.core_cortex_m7, QEMU mps2-an500). Plain C, no test
 * framework: each test prints its name and the first failed check; the last line says how many
 * failed, and the process exits with that count (semihosting on the target). */
#include "mfb_board.h"
#include "test_platform.h"

#include <stdio.h>
#include <string.h>

static int g_failed_checks;
static int g_failed_tests;
static int g_tests;
static const char* g_test;

#define CHECK(cond)                                                             \
  do {                                                                          \
    if (!(cond)) {                                                              \
      ++g_failed_checks;                                                        \
      printf("  FAILED %s:%d: %s\n", __FILE__, __LINE__, #cond);                \
    }                                                                           \
  } while (0)
#define CHECK_EQ(a, b)                                                                              \
  do {                                                                                              \
    const long long va_ = (long long)(a), vb_ = (long long)(b);                                     \
    if (va_ != vb_) {                                                                               \
      ++g_failed_checks;                                                                            \
      printf("  FAILED %s:%d: %s == %s (%lld vs %lld)\n", __FILE__, __LINE__, #a, #b, va_, vb_);    \
    }                                                                                               \
  } while (0)

static void run(void (*test)(void), const char* name) {
  const int before = g_failed_checks;
  g_test = name;
  ++g_tests;
  test();
  if (g_failed_checks != before) ++g_failed_tests;
  printf("%s %s\n", g_failed_checks == before ? "ok  " : "FAIL", name);
}

/* ---- a board on a bench: inputs set by the test, outputs and time captured ------------------- */

typedef struct bench {
  mfb_inputs in;
  uint16_t da[MFB_DA_CHANNELS];
  uint8_t digital_out;
  uint64_t now_us;
  uint32_t rng;
  int writes;
} bench;

static void bench_read(void* ctx, mfb_inputs* out) {
  bench* b = (bench*)ctx;
  *out = b->in;
  out->time_ns = b->now_us * 1000u; /* the sample clock is the board's clock */
}
static void bench_write(void* ctx, const uint16_t da[MFB_DA_CHANNELS], uint8_t dout) {
  bench* b = (bench*)ctx;
  memcpy(b->da, da, sizeof b->da);
  b->digital_out = dout;
  ++b->writes;
}
static uint64_t bench_now(void* ctx) { return ((bench*)ctx)->now_us; }
static uint32_t bench_random(void* ctx) {
  bench* b = (bench*)ctx; /* xorshift32: deterministic tokens for the tests */
  b->rng ^= b->rng << 13;
  b->rng ^= b->rng >> 17;
  b->rng ^= b->rng << 5;
  return b->rng;
}

/* The one-DOF rig's channel map (configs/mfb/one_dof_rig.yaml): valves 0..1 MPa on DA 0 and 1, the
 * motor +-3 Nm offset binary on DA 2, load cells 0..5000 N and 0..1000 N on AD 0 and 1, 70000
 * counts per joint revolution on encoder 0; enable on output line 0, e-stop active low on input 0. */
enum { kSafeValve = 0, kSafeMotor = 32768 };
static const double kPaPerCode = 1e6 / 65535.0;
static const double kNmPerCode = 9.1552734375e-5;
static const double kRadPerCount = 6.283185307179586 / 70000.0;

static mfb_board_si rig_si(void) {
  mfb_board_si si;
  memset(&si, 0, sizeof si);
  for (size_t i = 0; i < MFB_KEY_SIZE; ++i) si.key[i] = (uint8_t)i;
  si.watchdog_s = 0.010;
  si.vent_s = 2.0;
  si.safe_da[2] = kSafeMotor;
  si.estop_line = 0;
  si.estop_active_high = false;
  si.procedure_key_line = -1;
  si.joint_count = 1;
  mfb_joint_si* j = &si.joints[0];
  /* No slew limit to speak of (1000 MPa/s: the whole range within one period), no leads and no
   * stopping distance: the tests of those set their own. */
  j->muscle[0] = (mfb_muscle_si){{0, 0.0, kPaPerCode}, {0, 0.0, 5000.0 / 65535.0}, 0.8e6, 2000.0, 1e9, 0.0};
  j->muscle[1] = (mfb_muscle_si){{1, 0.0, kPaPerCode}, {1, 0.0, 1000.0 / 65535.0}, 0.8e6, 630.0, 1e9, 0.0};
  j->motor = (mfb_channel_si){2, -3.0, kNmPerCode};
  j->motor_ceiling_Nm = 2.5;
  j->encoder = (mfb_encoder_si){0, 0.0, kRadPerCount};
  j->min_angle_rad = -45.0 * 3.141592653589793 / 180.0;
  j->max_angle_rad = 45.0 * 3.141592653589793 / 180.0;
  return si;
}

static bench g_bench;
static mfb_hal g_hal;
static mfb_board_config g_cfg;
static mfb_board g_board;
static const mfb_endpoint kHost = {0x7F000001u, 40000};

/* Each power-on draws from another seed, as a hardware TRNG would differ between boots (the test
 * source is a deterministic xorshift, so that every run of these tests is the same). */
static uint32_t g_boots;

static void power_on_with(const mfb_board_si* si) {
  memset(&g_bench, 0, sizeof g_bench);
  g_bench.rng = 0x12345678u + 0x9E3779B9u * ++g_boots;
  g_bench.now_us = 1000000;
  g_bench.in.digital_in = 0x01; /* e-stop chain closed (active low): no e-stop */
  g_bench.in.ad[0] = 13107;     /* 1000 N */
  g_bench.in.ad[1] = 6553;      /* 100 N */
  g_hal = (mfb_hal){&g_bench, bench_read, bench_write, bench_now, test_mac, bench_random};
  char error[160];
  const bool ok = mfb_configure(si, &g_cfg, error, sizeof error);
  CHECK(ok);
  if (!ok) printf("  %s\n", error);
  mfb_board_init(&g_board, &g_cfg, &g_hal);
}
static void power_on(void) {
  const mfb_board_si si = rig_si();
  power_on_with(&si);
}

static uint32_t g_sequence;
static uint64_t g_nonce; /* the board nonce the test's host puts in its commands */

/* A recording of datagrams as a listener on the link captures them. */
typedef struct recording {
  uint8_t bytes[16][MFB_COMMAND_PACKET_SIZE];
  int count;
} recording;
static recording* g_recorder;

static void record(const uint8_t* bytes) {
  if (g_recorder != NULL && g_recorder->count < 16) memcpy(g_recorder->bytes[g_recorder->count++], bytes, MFB_COMMAND_PACKET_SIZE);
}

static uint64_t get_u64_at(const uint8_t* p, size_t at) {
  uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v |= (uint64_t)p[at + i] << (8 * i);
  return v;
}

/* A hello for host nonce `session` from `from`: returns the board nonce of the board's answer (read
 * from the answer's bytes, offset 102) and makes it the one the test's host sends. */
static uint64_t hello_from(mfb_endpoint from, uint32_t session) {
  mfb_command c;
  memset(&c, 0, sizeof c);
  c.type = MFB_TYPE_HELLO;
  c.session_id = session;
  c.sequence = ++g_sequence;
  uint8_t bytes[MFB_COMMAND_PACKET_SIZE];
  mfb_encode_command(&c, g_cfg.key, test_mac, NULL, bytes, sizeof bytes);
  record(bytes);
  mfb_verdict v;
  CHECK_EQ(mfb_board_receive(&g_board, bytes, sizeof bytes, from, &v), MFB_EVENT_ANSWER);
  CHECK_EQ(v, MFB_HELLO);
  uint8_t answer[MFB_STATE_PACKET_SIZE];
  mfb_endpoint to = {0, 0};
  CHECK_EQ(mfb_board_answer_packet(&g_board, answer, sizeof answer, &to), MFB_STATE_PACKET_SIZE);
  CHECK(to.address == from.address && to.port == from.port);
  CHECK_EQ(answer[101] & MFB_STATUS_NO_SESSION, MFB_STATUS_NO_SESSION);
  g_nonce = get_u64_at(answer, 102);
  CHECK(g_nonce != 0);
  return g_nonce;
}
static uint64_t hello(uint32_t session) { return hello_from(kHost, session); }

/* One command from `from`, encoded with the link's key, received, and (if it drives) applied. */
static mfb_event send_from(mfb_endpoint from, uint32_t session, uint8_t flags, const uint16_t da[MFB_DA_CHANNELS],
                           mfb_verdict* verdict) {
  g_bench.now_us += 1000; /* one board period per command */
  mfb_command c;
  memset(&c, 0, sizeof c);
  c.type = MFB_TYPE_COMMAND;
  c.session_id = session;
  c.sequence = ++g_sequence;
  c.host_time_ns = g_bench.now_us * 1000u;
  if (da != NULL) memcpy(c.da, da, sizeof c.da);
  c.digital_out = (flags & MFB_COMMAND_ENABLE) ? 0x01 : 0x00;
  c.flags = flags;
  c.board_nonce = g_nonce;
  uint8_t bytes[MFB_COMMAND_PACKET_SIZE];
  mfb_encode_command(&c, g_cfg.key, test_mac, NULL, bytes, sizeof bytes);
  record(bytes);
  const mfb_event e = mfb_board_receive(&g_board, bytes, sizeof bytes, from, verdict);
  mfb_board_sample(&g_board);
  if (e == MFB_EVENT_COMMAND) mfb_board_drive(&g_board);
  return e;
}
static mfb_event send(uint32_t session, uint8_t flags, const uint16_t da[MFB_DA_CHANNELS]) {
  return send_from(kHost, session, flags, da, NULL);
}

/* Hello, open `session`, acknowledge (enable clear), then the enable edge: outputs live. */
static void arm(uint32_t session, const uint16_t da[MFB_DA_CHANNELS]) {
  hello(session);
  send(session, 0, da);
  send(session, 0, da);
  send(session, MFB_COMMAND_ENABLE, da);
}

static const uint16_t kHalfBar[MFB_DA_CHANNELS] = {19661, 19661, 32768, 0, 0, 0, 0, 0}; /* 0.3 MPa, 0 Nm */
static const uint16_t kEverythingMax[MFB_DA_CHANNELS] = {65535, 65535, 65535, 65535, 65535, 65535, 65535, 65535};

/* ---- wire ---------------------------------------------------------------------------------------- */

/* The golden command of tests/mfb/protocol_test.cpp, its MAC made by Python's hashlib.blake2b under
 * the key 0x00..0x1F: the MAC on this machine (libsodium or the BLAKE2 reference) must agree. */
static const uint8_t kGoldenCommand[MFB_COMMAND_PACKET_SIZE] = {
    0x4D, 0x46, 0x42, 0x31, 0x05, 0x01, 0x22, 0x00, 0x44, 0x33, 0x22, 0x11, 0x88, 0x77, 0x66, 0x55,
    0x08, 0x07, 0x06, 0x05, 0x04, 0x03, 0x02, 0x01, 0xB0, 0xA0, 0xB1, 0xA1, 0xB2, 0xA2, 0xB3, 0xA3,
    0xB4, 0xA4, 0xB5, 0xA5, 0xB6, 0xA6, 0xB7, 0xA7, 0xC3, 0x01, 0xF8, 0xF7, 0xF6, 0xF5, 0xF4, 0xF3,
    0xF2, 0xF1, 0x96, 0x87, 0xB6, 0xFE, 0x64, 0xEE, 0xD9, 0xBD, 0xED, 0x42, 0x91, 0x36, 0xB2, 0x09,
    0x17, 0x1D, 0x01, 0xB4, 0x17, 0x6D};

static const uint8_t kGoldenState[MFB_STATE_PACKET_SIZE] = {
    0x4D, 0x46, 0x42, 0x31, 0x05, 0x02, 0x65, 0x00, 0x44, 0x33, 0x22, 0x11, 0x0D, 0x0C, 0x0B, 0x0A,
    0x08, 0x07, 0x06, 0x05, 0x04, 0x03, 0x02, 0x01, 0x18, 0x17, 0x16, 0x15, 0x14, 0x13, 0x12, 0x11,
    0x88, 0x77, 0x66, 0x55, 0xE0, 0xD0, 0xE1, 0xD1, 0xE2, 0xD2, 0xE3, 0xD3, 0xE4, 0xD4, 0xE5, 0xD5,
    0xE6, 0xD6, 0xE7, 0xD7, 0xE8, 0xD8, 0xE9, 0xD9, 0xEA, 0xDA, 0xEB, 0xDB, 0xEC, 0xDC, 0xED, 0xDD,
    0xEE, 0xDE, 0xEF, 0xDF, 0xFF, 0xFF, 0xFF, 0xFF, 0x01, 0x00, 0x00, 0x00, 0xFF, 0xFF, 0xFF, 0x7F,
    0x00, 0x00, 0x00, 0x80, 0xEB, 0x32, 0xA4, 0xF8, 0x04, 0x03, 0x02, 0x01, 0x00, 0x00, 0x00, 0x00,
    0xFE, 0xFF, 0xFF, 0xFF, 0x5A, 0x0A, 0x28, 0x27, 0x26, 0x25, 0x24, 0x23, 0x22, 0x21, 0x34, 0x33,
    0x32, 0x31, 0x21, 0x84, 0x5C, 0xE7, 0x46, 0xFF, 0x50, 0x7A, 0xF9, 0xFF, 0x78, 0x91, 0xBA, 0x3A,
    0xE7, 0xE8, 0x8F, 0x42, 0x88, 0x9C, 0x3F, 0xDB, 0xB7};

static uint8_t g_key[MFB_KEY_SIZE];
static void golden_key(void) {
  for (size_t i = 0; i < MFB_KEY_SIZE; ++i) g_key[i] = (uint8_t)i;
}

static void Crc32cHasTheCastagnoliCheckValue(void) {
  CHECK_EQ(mfb_crc32c((const uint8_t*)"123456789", 9), 0xE3069283u);
}

static void GoldenCommandDecodesWithItsPythonMac(void) {
  golden_key();
  mfb_command c;
  CHECK_EQ(mfb_decode_command(kGoldenCommand, sizeof kGoldenCommand, g_key, test_mac, NULL, &c), MFB_PARSE_OK);
  CHECK_EQ(c.session_id, 0x11223344u);
  CHECK_EQ(c.sequence, 0x55667788u);
  CHECK_EQ(c.host_time_ns, 0x0102030405060708ull);
  CHECK_EQ(c.da[7], 0xA7B7);
  CHECK_EQ(c.type, MFB_TYPE_COMMAND);
  CHECK(c.board_nonce == 0xF1F2F3F4F5F6F7F8ull);
  CHECK_EQ(c.flags, MFB_COMMAND_ENABLE);
  /* Every single-bit flip is refused: in the CRC-covered bytes as a bad CRC, in the MAC as a bad MAC. */
  int refused = 0;
  for (size_t bit = 0; bit < 8 * sizeof kGoldenCommand; ++bit) {
    uint8_t copy[MFB_COMMAND_PACKET_SIZE];
    memcpy(copy, kGoldenCommand, sizeof copy);
    copy[bit / 8] ^= (uint8_t)(1u << (bit % 8));
    if (mfb_decode_command(copy, sizeof copy, g_key, test_mac, NULL, &c) != MFB_PARSE_OK) ++refused;
  }
  CHECK_EQ(refused, 8 * MFB_COMMAND_PACKET_SIZE);
}

static void GoldenStateEncodesToItsBytes(void) {
  golden_key();
  mfb_state s = {0x11223344u, 0x0A0B0C0Du, 0x55667788u, 0x0102030405060708ull, 0x1112131415161718ull, {0}, {0},
                 0x5A, MFB_STATUS_OUTPUTS_SAFE | MFB_STATUS_NO_SESSION, 0x2122232425262728ull, 0x31323334u, 0x8421, 0x5C};
  for (int i = 0; i < MFB_AD_CHANNELS; ++i) s.ad[i] = (uint16_t)(0xD0E0 + 0x0101 * i);
  const int32_t enc[MFB_ENCODER_CHANNELS] = {-1, 1, INT32_MAX, INT32_MIN, -123456789, 0x01020304, 0, -2};
  memcpy(s.encoder, enc, sizeof enc);
  uint8_t out[MFB_STATE_PACKET_SIZE];
  CHECK_EQ(mfb_encode_state(&s, g_key, test_mac, NULL, out, sizeof out), MFB_STATE_PACKET_SIZE);
  CHECK(memcmp(out, kGoldenState, sizeof out) == 0);
  CHECK_EQ(mfb_encode_state(&s, g_key, test_mac, NULL, out, sizeof out - 1), 0);
}

static void ChecksRunInTheProtocolsOrder(void) {
  golden_key();
  mfb_command c;
  uint8_t copy[MFB_COMMAND_PACKET_SIZE + 1];
  memcpy(copy, kGoldenCommand, MFB_COMMAND_PACKET_SIZE);
  CHECK_EQ(mfb_decode_command(copy, 15, g_key, test_mac, NULL, &c), MFB_PARSE_TOO_SHORT);
  CHECK_EQ(mfb_decode_command(copy, MFB_COMMAND_PACKET_SIZE - 1, g_key, test_mac, NULL, &c), MFB_PARSE_TOO_SHORT);
  CHECK_EQ(mfb_decode_command(copy, MFB_COMMAND_PACKET_SIZE + 1, g_key, test_mac, NULL, &c), MFB_PARSE_TOO_LONG);
  copy[4] = 4; /* version 4 also differs in size: the version is reported */
  CHECK_EQ(mfb_decode_command(copy, MFB_COMMAND_PACKET_SIZE - 4, g_key, test_mac, NULL, &c), MFB_PARSE_BAD_VERSION);
  memcpy(copy, kGoldenCommand, MFB_COMMAND_PACKET_SIZE);
  copy[5] = MFB_TYPE_STATE;
  CHECK_EQ(mfb_decode_command(copy, MFB_COMMAND_PACKET_SIZE, g_key, test_mac, NULL, &c), MFB_PARSE_WRONG_TYPE);
  g_key[0] ^= 1; /* another key */
  CHECK_EQ(mfb_decode_command(kGoldenCommand, MFB_COMMAND_PACKET_SIZE, g_key, test_mac, NULL, &c), MFB_PARSE_BAD_MAC);
}

/* ---- session and arming --------------------------------------------------------------------------- */

static void NothingIsSentAndOutputsAreSafeBeforeTheFirstSession(void) {
  power_on();
  uint8_t out[MFB_STATE_PACKET_SIZE];
  CHECK_EQ(mfb_board_state_packet(&g_board, out, sizeof out), 0);
  CHECK_EQ(g_bench.da[0], kSafeValve);
  CHECK_EQ(g_bench.da[2], kSafeMotor);
  CHECK_EQ(g_bench.digital_out, 0);
  CHECK(g_board.boot_id != 0);
}

static void AnEnableEdgeOfTheSessionArmsTheOutputs(void) {
  power_on();
  hello(7);
  CHECK_EQ(send(7, MFB_COMMAND_ENABLE, kHalfBar), MFB_EVENT_NEW_SESSION);
  send(7, MFB_COMMAND_ENABLE, kHalfBar); /* enable without a preceding disable: no edge */
  CHECK(!mfb_board_outputs_live(&g_board));
  CHECK_EQ(g_bench.da[0], kSafeValve);
  send(7, 0, kHalfBar);
  send(7, MFB_COMMAND_ENABLE, kHalfBar);
  CHECK(mfb_board_outputs_live(&g_board));
  CHECK_EQ(g_bench.da[0], 19661);
  CHECK_EQ(g_bench.digital_out, 0x01);
  CHECK_EQ(mfb_board_status(&g_board), 0);
}

/* ---- the handshake: replays -------------------------------------------------------------------- */

static const mfb_endpoint kListener = {0x7F000001u, 47000}; /* another process on the link, with the key */

/* Every datagram of `r` from `from`; returns how many the board accepted (it must send no command
 * of them to the outputs). */
static int replay(const recording* r, mfb_endpoint from) {
  int accepted = 0;
  for (int i = 0; i < r->count; ++i) {
    mfb_verdict v;
    const mfb_event e = mfb_board_receive(&g_board, r->bytes[i], MFB_COMMAND_PACKET_SIZE, from, &v);
    if (v == MFB_ACCEPT) ++accepted;
    if (e == MFB_EVENT_COMMAND || e == MFB_EVENT_NEW_SESSION) mfb_board_drive(&g_board);
  }
  return accepted;
}

/* A host's whole armed session, recorded: hello, open, acknowledge, the enable edge, a command. */
static void record_an_armed_session(recording* r, uint32_t session) {
  memset(r, 0, sizeof *r);
  g_recorder = r;
  arm(session, kEverythingMax);
  send(session, MFB_COMMAND_ENABLE, kEverythingMax);
  g_recorder = NULL;
  CHECK(mfb_board_outputs_live(&g_board));
}

/* The real host after a replay: it opens its own session and arms (the operator's arming, which a
 * host loss wants and an ordinary edge does not mind), as if no replay had been. */
static void the_real_host_connects_normally(uint32_t session) {
  const uint64_t before = mfb_board_counters(&g_board)->accepted;
  hello(session);
  send(session, 0, kHalfBar);
  send(session, 0, kHalfBar);
  send(session, MFB_COMMAND_ENABLE | MFB_COMMAND_OPERATOR_ARM, kHalfBar);
  CHECK(mfb_board_outputs_live(&g_board));
  CHECK_EQ(g_bench.da[0], 19661);
  CHECK_EQ(mfb_board_counters(&g_board)->accepted - before, 3);
}

static void ARecordedSessionReplayedToARebootedBoardIsRefused(void) {
  power_on();
  recording r;
  record_an_armed_session(&r, 7);
  power_on(); /* a restart: a new boot secret */
  CHECK_EQ(replay(&r, kListener), 0);
  CHECK_EQ(replay(&r, kHost), 0); /* from the host's own address (spoofed) too */
  CHECK(!mfb_board_has_session(&g_board));
  CHECK(!mfb_board_outputs_live(&g_board));
  CHECK_EQ(g_bench.da[0], kSafeValve);
  CHECK_EQ(g_bench.da[2], kSafeMotor);
  CHECK_EQ(mfb_board_counters(&g_board)->unknown_session, 2 * (r.count - 1)); /* every command; the hellos answered */
  uint8_t out[MFB_STATE_PACKET_SIZE];
  CHECK_EQ(mfb_board_state_packet(&g_board, out, sizeof out), 0); /* it sends nobody its stream */
  the_real_host_connects_normally(8);
}

static void ARecordedSessionReplayedToTheSameBootLaterIsRefused(void) {
  power_on();
  recording r;
  record_an_armed_session(&r, 7);
  g_bench.now_us += 20000; /* the host is gone: the watchdog lets its session go */
  CHECK_EQ(mfb_board_poll(&g_board), MFB_WATCHDOG_HOST_LOST);
  CHECK_EQ(replay(&r, kListener), 0); /* another endpoint: not the nonce answered to it */
  CHECK_EQ(replay(&r, kHost), 0);     /* the host's endpoint: all older than the session's last */
  CHECK(!mfb_board_outputs_live(&g_board));
  the_real_host_connects_normally(8);
}

static void AReplayedArmingDoesNotArm(void) {
  power_on();
  recording r;
  memset(&r, 0, sizeof r);
  arm(7, kHalfBar);
  g_bench.now_us += 20000;
  mfb_board_poll(&g_board); /* host loss: only the operator's arming arms */
  g_recorder = &r;          /* the operator arms a new session: recorded */
  hello(9);
  send(9, 0, kHalfBar);
  send(9, MFB_COMMAND_ENABLE | MFB_COMMAND_OPERATOR_ARM, kEverythingMax);
  g_recorder = NULL;
  CHECK(mfb_board_outputs_live(&g_board));
  g_bench.now_us += 20000;
  mfb_board_poll(&g_board); /* host loss again */
  CHECK_EQ(replay(&r, kListener), 0);
  CHECK_EQ(replay(&r, kHost), 0);
  CHECK(!mfb_board_outputs_live(&g_board));
  power_on();
  CHECK_EQ(replay(&r, kHost), 0);
  CHECK(!mfb_board_outputs_live(&g_board));
  CHECK_EQ(g_bench.da[0], kSafeValve);
}

static void ASecondSourceWithTheKeyCannotSpeakForTheSession(void) {
  power_on();
  arm(7, kHalfBar);
  const uint64_t nonce = g_nonce;
  mfb_verdict v;
  CHECK_EQ(send_from(kListener, 7, MFB_COMMAND_ENABLE, kEverythingMax, &v), MFB_EVENT_DROPPED);
  CHECK_EQ(v, MFB_FOREIGN_SOURCE);
  hello_from(kListener, 7); /* even its own handshake for the same host nonce */
  CHECK(g_nonce != nonce);
  CHECK_EQ(send_from(kListener, 7, MFB_COMMAND_ENABLE, kEverythingMax, &v), MFB_EVENT_DROPPED);
  CHECK_EQ(v, MFB_FOREIGN_SOURCE);
  g_nonce = nonce;
  send(7, MFB_COMMAND_ENABLE, kHalfBar);
  CHECK(mfb_board_outputs_live(&g_board));
  CHECK_EQ(g_bench.da[0], 19661);
}

static void TheBoardNonceIsFreshPerBootAndPerSession(void) {
  power_on();
  const uint32_t boot_a = mfb_board_boot_id(&g_board);
  const uint64_t a = hello(7);
  CHECK(hello(7) == a); /* the same question in the same epoch: the same answer, no state kept */
  CHECK(hello_from(kListener, 7) != a); /* bound to the endpoint */
  g_nonce = a;
  send(7, 0, kHalfBar); /* opens the session: a new epoch */
  CHECK(hello(7) != a);
  power_on();
  CHECK(mfb_board_boot_id(&g_board) != boot_a);
  CHECK(hello(7) != a); /* another boot: another secret */
}

static void AHelloDrivesNothingAndLeavesTheSessionAlone(void) {
  power_on();
  arm(7, kHalfBar);
  const uint64_t nonce = g_nonce;
  hello_from(kListener, 9);
  CHECK(mfb_board_has_session(&g_board));
  CHECK_EQ(mfb_board_session(&g_board), 7);
  CHECK(mfb_board_nonce(&g_board) == nonce);
  CHECK(mfb_board_outputs_live(&g_board));
  mfb_command c;
  memset(&c, 0, sizeof c);
  c.type = MFB_TYPE_HELLO;
  c.session_id = 9;
  c.da[0] = 1; /* a hello with an output */
  uint8_t bytes[MFB_COMMAND_PACKET_SIZE];
  mfb_encode_command(&c, g_cfg.key, test_mac, NULL, bytes, sizeof bytes);
  mfb_command out;
  CHECK_EQ(mfb_decode_command(bytes, sizeof bytes, g_cfg.key, test_mac, NULL, &out), MFB_PARSE_BAD_FLAGS);
}

static void TheSessionBelongsToItsEndpointAndSequenceOnlyMovesForward(void) {
  power_on();
  arm(7, kHalfBar);
  mfb_verdict v;
  const mfb_endpoint other_port = {kHost.address, (uint16_t)(kHost.port + 1)};
  CHECK_EQ(send_from(other_port, 7, MFB_COMMAND_ENABLE, kEverythingMax, &v), MFB_EVENT_DROPPED);
  CHECK_EQ(v, MFB_FOREIGN_SOURCE);
  CHECK_EQ(send_from(kHost, 8, MFB_COMMAND_ENABLE, kEverythingMax, &v), MFB_EVENT_DROPPED);
  CHECK_EQ(v, MFB_FOREIGN_SESSION);
  g_sequence -= 4; /* two dropped, then older than the last accepted */
  CHECK_EQ(send_from(kHost, 7, MFB_COMMAND_ENABLE, kEverythingMax, &v), MFB_EVENT_DROPPED);
  CHECK_EQ(v, MFB_STALE);
  CHECK_EQ(g_bench.da[0], 19661); /* still the session's own command */
  const mfb_counters* n = mfb_board_counters(&g_board);
  CHECK_EQ(n->accepted, 3);
  CHECK_EQ(n->foreign_source + n->foreign_session + n->stale, 3);
}

static void TheWatchdogCutsTheMotorAndVentsAlongTheRamp(void) {
  power_on();
  arm(7, kHalfBar);
  CHECK_EQ(mfb_board_poll(&g_board), MFB_WATCHDOG_QUIET);
  g_bench.now_us += 10001; /* watchdog 10 ms */
  CHECK_EQ(mfb_board_poll(&g_board), MFB_WATCHDOG_HOST_LOST);
  mfb_board_drive(&g_board);
  CHECK_EQ(g_bench.da[2], kSafeMotor); /* motor at once */
  CHECK_EQ(g_bench.da[0], 19661);      /* valves start the ramp where they were */
  CHECK_EQ(g_bench.digital_out, 0);
  g_bench.now_us += 1000000; /* half of vent_s = 2 s */
  mfb_board_drive(&g_board);
  CHECK_EQ(g_bench.da[0], 9831); /* 19661 / 2, rounded */
  g_bench.now_us += 1000000;
  mfb_board_drive(&g_board);
  CHECK_EQ(g_bench.da[0], kSafeValve);
  CHECK_EQ(mfb_board_status(&g_board),
           MFB_STATUS_WATCHDOG_TRIPPED | MFB_STATUS_OUTPUTS_SAFE | MFB_STATUS_NO_SESSION | MFB_STATUS_HOST_LOST);
}

static void AfterAHostLossOnlyTheOperatorsArmingArms(void) {
  power_on();
  arm(7, kHalfBar);
  g_bench.now_us += 20000;
  mfb_board_poll(&g_board);
  arm(9, kHalfBar); /* a new host, ordinary edge */
  CHECK(!mfb_board_outputs_live(&g_board));
  send(9, 0, kHalfBar);
  send(9, MFB_COMMAND_ENABLE | MFB_COMMAND_OPERATOR_ARM, kHalfBar);
  CHECK(mfb_board_outputs_live(&g_board));
  CHECK_EQ(mfb_board_status(&g_board) & MFB_STATUS_HOST_LOST, 0);
}

static void AnEstopDisarmsAndTheEdgeMustFollowItsRelease(void) {
  power_on();
  arm(7, kHalfBar);
  g_bench.in.digital_in = 0x00; /* the chain opens: e-stop */
  send(7, MFB_COMMAND_ENABLE, kHalfBar);
  CHECK(!mfb_board_outputs_live(&g_board));
  CHECK(mfb_board_status(&g_board) & MFB_STATUS_ESTOP);
  send(7, 0, kHalfBar); /* disabled while the e-stop is still active: no edge yet */
  g_bench.in.digital_in = 0x01;
  send(7, MFB_COMMAND_ENABLE, kHalfBar);
  CHECK(!mfb_board_outputs_live(&g_board));
  send(7, 0, kHalfBar);
  send(7, MFB_COMMAND_ENABLE, kHalfBar);
  CHECK(mfb_board_outputs_live(&g_board));
}

/* ---- the board's own limits ----------------------------------------------------------------------- */

static void AHijackingHostGetsNoMoreThanTheCeilings(void) {
  power_on();
  arm(7, kEverythingMax);
  CHECK(mfb_board_outputs_live(&g_board));
  CHECK_EQ(g_bench.da[0], 52428); /* 0.8 MPa: the pressure ceiling, not 1.0 MPa */
  CHECK_EQ(g_bench.da[1], 52428);
  CHECK_EQ(g_bench.da[2], 60074); /* +2.5 Nm (code 60074.7 rounded inwards), not +3 Nm */
  CHECK_EQ(g_bench.da[3], 65535); /* an unlimited channel passes */
  const uint16_t min[MFB_DA_CHANNELS] = {0, 0, 0, 0, 0, 0, 0, 0};
  send(7, MFB_COMMAND_ENABLE, min);
  CHECK_EQ(g_bench.da[2], 5462); /* -2.5 Nm */
  CHECK_EQ(mfb_board_counters(&g_board)->clamped, 3 + 1);
}

static void ALoadCellOverItsCeilingVentsThatMuscleOnly(void) {
  power_on();
  arm(7, kHalfBar);
  g_bench.in.ad[0] = 26214; /* exactly 2000 N: at the ceiling, not over */
  send(7, MFB_COMMAND_ENABLE, kHalfBar);
  CHECK_EQ(g_bench.da[0], 19661);
  g_bench.in.ad[0] = 26215; /* 2000.08 N */
  send(7, MFB_COMMAND_ENABLE, kHalfBar);
  CHECK_EQ(g_bench.da[0], kSafeValve);
  CHECK_EQ(g_bench.da[1], 19661); /* the antagonist keeps its command */
  CHECK_EQ(g_bench.da[2], kSafeMotor + 0);
  g_bench.in.ad[0] = 13107; /* back to 1000 N: the vent holds until an arming edge */
  send(7, MFB_COMMAND_ENABLE, kHalfBar);
  CHECK_EQ(g_bench.da[0], kSafeValve);
  send(7, 0, kHalfBar);
  send(7, MFB_COMMAND_ENABLE, kHalfBar);
  CHECK_EQ(g_bench.da[0], 19661);
  CHECK_EQ(mfb_board_counters(&g_board)->force_trips, 1);
}

static void ATripSurvivesAnEdgeWhileItsCauseRemains(void) {
  power_on();
  arm(7, kHalfBar);
  g_bench.in.ad[1] = 45000; /* antagonist at 687 N > 630 N */
  send(7, MFB_COMMAND_ENABLE, kHalfBar);
  send(7, 0, kHalfBar);
  send(7, MFB_COMMAND_ENABLE, kHalfBar);
  CHECK(mfb_board_outputs_live(&g_board));
  CHECK_EQ(g_bench.da[1], kSafeValve);
}

/* An arming edge releases a force trip only once its load cell is below half the ceiling (1000 N of
 * 2000): refilled from nearer the ceiling, the valve's dead time and lag carry the force past it. */
static void AnEdgeReleasesAForceTripOnlyBelowHalfItsCeiling(void) {
  power_on();
  arm(7, kHalfBar);
  g_bench.in.ad[0] = 26215; /* 2000.08 N */
  send(7, MFB_COMMAND_ENABLE, kHalfBar);
  CHECK_EQ(g_bench.da[0], kSafeValve);
  g_bench.in.ad[0] = 13120; /* 1001 N: under the ceiling, not under half of it */
  send(7, 0, kHalfBar);
  send(7, MFB_COMMAND_ENABLE, kHalfBar);
  CHECK(mfb_board_outputs_live(&g_board));
  CHECK_EQ(g_bench.da[0], kSafeValve);
  g_bench.in.ad[0] = 13107; /* 1000 N */
  send(7, 0, kHalfBar);
  send(7, MFB_COMMAND_ENABLE, kHalfBar);
  CHECK_EQ(g_bench.da[0], 19661);
}

/* Both muscles of a joint tripped: the agonist below half its ceiling (500 N) stays vented while the
 * antagonist is not (400 N, half is 315 N) - released alone it would pull the limb against nothing -
 * and both are released by the edge that finds both below half. */
static void AJointsTrippedMusclesAreReleasedTogether(void) {
  power_on();
  arm(7, kHalfBar);
  g_bench.in.ad[0] = 26215; /* 2000.08 N */
  g_bench.in.ad[1] = 45000; /* 687 N > 630 N */
  send(7, MFB_COMMAND_ENABLE, kHalfBar);
  CHECK_EQ(g_bench.da[0], kSafeValve);
  CHECK_EQ(g_bench.da[1], kSafeValve);
  g_bench.in.ad[0] = 6553;  /* 500 N */
  g_bench.in.ad[1] = 26214; /* 400 N */
  send(7, 0, kHalfBar);
  send(7, MFB_COMMAND_ENABLE, kHalfBar);
  CHECK(mfb_board_outputs_live(&g_board));
  CHECK_EQ(g_bench.da[0], kSafeValve);
  CHECK_EQ(g_bench.da[1], kSafeValve);
  g_bench.in.ad[1] = 19661; /* 300 N */
  send(7, 0, kHalfBar);
  send(7, MFB_COMMAND_ENABLE, kHalfBar);
  CHECK_EQ(g_bench.da[0], 19661);
  CHECK_EQ(g_bench.da[1], 19661);
  /* One muscle tripped alone is released by itself. */
  g_bench.in.ad[1] = 45000;
  send(7, MFB_COMMAND_ENABLE, kHalfBar);
  g_bench.in.ad[1] = 19661;
  send(7, 0, kHalfBar);
  send(7, MFB_COMMAND_ENABLE, kHalfBar);
  CHECK_EQ(g_bench.da[0], 19661);
  CHECK_EQ(g_bench.da[1], 19661);
}

/* A force trip that holds keeps its joint's range trip too: the link out above the range (the
 * agonist vented by the range) with its antagonist tripped at its ceiling, then back inside. The
 * edge that finds the antagonist still above half its ceiling (400 N) keeps the agonist vented and
 * the motor cut - released alone, the agonist would swing the link against a vented antagonist -
 * and the edge that finds it below (300 N) releases all. */
static void AForceTripThatHoldsKeepsItsJointsRangeTrip(void) {
  mfb_board_si si = rig_si();
  si.joints[0].range_vent = true;
  power_on_with(&si);
  uint16_t torque[MFB_DA_CHANNELS] = {19661, 19661, 40000, 0, 0, 0, 0, 0};
  arm(7, torque);
  g_bench.in.encoder[0] = 8751; /* above the range */
  g_bench.in.ad[1] = 45000;     /* 687 N > 630 N */
  send(7, MFB_COMMAND_ENABLE, torque);
  CHECK_EQ(g_bench.da[0], kSafeValve);
  CHECK_EQ(g_bench.da[1], kSafeValve);
  CHECK_EQ(g_bench.da[2], kSafeMotor);
  g_bench.in.encoder[0] = 0; /* back inside, still for the window */
  g_bench.in.ad[1] = 26214;  /* 400 N */
  for (int k = 0; k < MFB_RATE_WINDOW; ++k) send(7, 0, torque);
  send(7, MFB_COMMAND_ENABLE, torque);
  CHECK(mfb_board_outputs_live(&g_board));
  CHECK_EQ(g_bench.da[0], kSafeValve);
  CHECK_EQ(g_bench.da[1], kSafeValve);
  CHECK_EQ(g_bench.da[2], kSafeMotor);
  g_bench.in.ad[1] = 19661; /* 300 N */
  send(7, 0, torque);
  send(7, MFB_COMMAND_ENABLE, torque);
  CHECK_EQ(g_bench.da[0], 19661);
  CHECK_EQ(g_bench.da[1], 19661);
  CHECK_EQ(g_bench.da[2], 40000);
}

/* The range's vent needs the other muscle to brake. The agonist tripped at its ceiling (the swing up)
 * and the link then out below the range: the range vents the antagonist, and the agonist's own trip
 * lets it refill once its load cell is below half its ceiling, without waiting for an arming edge.
 * Without range_vent nothing brakes for the range and the trip holds until the edge. */
static void ARangeTripReleasesTheForceTripOfTheMuscleThatBrakes(void) {
  for (int vent = 1; vent >= 0; --vent) {
    mfb_board_si si = rig_si();
    si.joints[0].range_vent = vent != 0;
    power_on_with(&si);
    uint16_t torque[MFB_DA_CHANNELS] = {19661, 19661, 40000, 0, 0, 0, 0, 0};
    arm(7, torque);
    g_bench.in.ad[0] = 26215; /* 2000.08 N */
    send(7, MFB_COMMAND_ENABLE, torque);
    CHECK_EQ(g_bench.da[0], kSafeValve);
    g_bench.in.ad[0] = 19661;      /* 1500 N, falling */
    g_bench.in.encoder[0] = -8751; /* below the range: the antagonist drives it out */
    send(7, MFB_COMMAND_ENABLE, torque);
    CHECK_EQ(g_bench.da[2], kSafeMotor);
    CHECK_EQ(g_bench.da[0], kSafeValve); /* above half its ceiling: the trip holds */
    CHECK_EQ(g_bench.da[1], vent ? kSafeValve : 19661);
    g_bench.in.ad[0] = 13107; /* 1000 N */
    send(7, MFB_COMMAND_ENABLE, torque);
    CHECK_EQ(g_bench.da[0], vent ? 19661 : kSafeValve); /* it brakes */
    CHECK_EQ(g_bench.da[1], vent ? kSafeValve : 19661);
  }
}

static void AJointOutOfRangeTurnsItsMotorOffAndKeepsTheMuscles(void) {
  power_on();
  uint16_t torque[MFB_DA_CHANNELS] = {19661, 19661, 40000, 0, 0, 0, 0, 0}; /* +0.66 Nm */
  arm(7, torque);
  g_bench.in.encoder[0] = 8751;
  send(7, MFB_COMMAND_ENABLE, torque);
  CHECK_EQ(g_bench.da[2], kSafeMotor);
  CHECK_EQ(g_bench.da[0], 19661); /* without range_vent the muscles keep their commands */
  CHECK_EQ(g_bench.da[1], 19661);
  CHECK_EQ(mfb_board_counters(&g_board)->range_trips, 1);
}

static void AJointOutOfRangeCutsItsMotorAndVentsTheMuscleDrivingItOut(void) {
  mfb_board_si si = rig_si();
  si.joints[0].range_vent = true;
  power_on_with(&si);
  uint16_t torque[MFB_DA_CHANNELS] = {19661, 19661, 40000, 0, 0, 0, 0, 0}; /* +0.66 Nm */
  arm(7, torque);
  CHECK_EQ(g_bench.da[2], 40000);
  g_bench.in.encoder[0] = 8750; /* 45.0 deg: the edge of the range, inside */
  send(7, MFB_COMMAND_ENABLE, torque);
  CHECK_EQ(g_bench.da[2], 40000);
  g_bench.in.encoder[0] = 8751; /* above: the agonist drives the angle up */
  send(7, MFB_COMMAND_ENABLE, torque);
  CHECK_EQ(g_bench.da[2], kSafeMotor);
  CHECK_EQ(g_bench.da[0], kSafeValve);
  CHECK_EQ(g_bench.da[1], 19661); /* the antagonist brakes and holds the limb */
  g_bench.in.encoder[0] = 0; /* back inside: latched, the agonist stays vented */
  send(7, MFB_COMMAND_ENABLE, torque);
  CHECK_EQ(g_bench.da[0], kSafeValve);
  g_bench.in.encoder[0] = -8751; /* swung out below: now the antagonist drives it out, the agonist brakes */
  send(7, MFB_COMMAND_ENABLE, torque);
  CHECK_EQ(g_bench.da[2], kSafeMotor);
  CHECK_EQ(g_bench.da[0], 19661);
  CHECK_EQ(g_bench.da[1], kSafeValve);
  CHECK_EQ(mfb_board_counters(&g_board)->range_trips, 1);
  send(7, 0, torque); /* an edge while out: the trip stays */
  send(7, MFB_COMMAND_ENABLE, torque);
  CHECK(mfb_board_outputs_live(&g_board));
  CHECK_EQ(g_bench.da[1], kSafeValve);
  g_bench.in.encoder[0] = 0; /* back inside (and still, for the window): the next edge clears it */
  for (int k = 0; k < MFB_RATE_WINDOW; ++k) send(7, 0, torque);
  send(7, MFB_COMMAND_ENABLE, torque);
  CHECK_EQ(g_bench.da[1], 19661);
  CHECK_EQ(g_bench.da[2], 40000);
}

/* The state packet tells the host what the limits cut (bytes 114..116): bit 2 x joint + muscle of
 * each muscle a limit vents, bit joint of each motor the range cuts; 0 while nothing trips. */
static void TheStatePacketTellsTheHostWhichMusclesAndMotorsTheLimitsCut(void) {
  mfb_board_si si = rig_si();
  si.joints[0].range_vent = true;
  power_on_with(&si);
  uint16_t torque[MFB_DA_CHANNELS] = {19661, 19661, 40000, 0, 0, 0, 0, 0};
  arm(7, torque);
  uint8_t out[MFB_STATE_PACKET_SIZE];
  CHECK_EQ(mfb_board_state_packet(&g_board, out, sizeof out), MFB_STATE_PACKET_SIZE);
  CHECK_EQ(out[114] | out[115] | out[116], 0);
  g_bench.in.encoder[0] = -8751; /* below the range: the antagonist drives it out */
  send(7, MFB_COMMAND_ENABLE, torque);
  CHECK_EQ(mfb_board_state_packet(&g_board, out, sizeof out), MFB_STATE_PACKET_SIZE);
  CHECK_EQ(out[114], 0x02); /* joint 0's antagonist */
  CHECK_EQ(out[115], 0x00);
  CHECK_EQ(out[116], 0x01); /* joint 0's motor */
  g_bench.in.ad[0] = 30000; /* and the agonist's load cell at 2289 N > 2000 N */
  send(7, MFB_COMMAND_ENABLE, torque);
  CHECK_EQ(mfb_board_state_packet(&g_board, out, sizeof out), MFB_STATE_PACKET_SIZE);
  CHECK_EQ(out[114], 0x03);
}

/* The procedure key (input line 1, active high) lets a procedure drive the joint onto its stop: the
 * motor is still cut outside the range, the muscles keep their commands; without the key the same
 * sample vents the agonist. No command bit reaches the key: it is an input, and it counts only when
 * turned before the arming edge. */
static void TheProcedureKeyKeepsTheMusclesOutsideTheRangeAndStillCutsTheMotor(void) {
  mfb_board_si si = rig_si();
  si.joints[0].range_vent = true;
  si.procedure_key_line = 1;
  si.procedure_key_active_high = true;
  power_on_with(&si);
  uint16_t torque[MFB_DA_CHANNELS] = {19661, 19661, 40000, 0, 0, 0, 0, 0};
  g_bench.in.digital_in = 0x03; /* no e-stop, the key turned */
  arm(7, torque);
  g_bench.in.encoder[0] = 9500; /* 48.9 deg: on the stop */
  send(7, MFB_COMMAND_ENABLE, torque);
  CHECK_EQ(g_bench.da[2], kSafeMotor);
  CHECK_EQ(g_bench.da[0], 19661);
  CHECK_EQ(g_bench.da[1], 19661);
  g_bench.in.digital_in = 0x01; /* the key turned back: the range vents at once */
  send(7, MFB_COMMAND_ENABLE, torque);
  CHECK_EQ(g_bench.da[0], kSafeValve);
  CHECK_EQ(g_bench.da[1], 19661);
  /* A key turned while a run is armed does not switch the range vent off: it counts from the next
   * arming edge only. */
  g_bench.in.encoder[0] = 0;
  for (int k = 0; k < MFB_RATE_WINDOW; ++k) send(7, 0, torque);
  send(7, MFB_COMMAND_ENABLE, torque); /* armed without the key */
  CHECK_EQ(g_bench.da[0], 19661);
  g_bench.in.digital_in = 0x03; /* turned mid-run */
  g_bench.in.encoder[0] = 9500;
  send(7, MFB_COMMAND_ENABLE, torque);
  CHECK_EQ(g_bench.da[2], kSafeMotor);
  CHECK_EQ(g_bench.da[0], kSafeValve);
  si.procedure_key_line = 0; /* the e-stop's line cannot be the key's */
  char error[160];
  mfb_board_config cfg;
  CHECK(!mfb_configure(&si, &cfg, error, sizeof error));
}

/* The range led by the speed: 20 ms of valve reaction and 1000 deg/s^2 of braking. At 298 deg/s
 * (58 counts per 1 ms period) the joint needs 6 deg of lead plus 44.5 deg to stop, so it trips near
 * -5 deg going up; an arming edge releases the trip only 5 % of the span inside the range; moving as
 * slowly as a legitimate host moves it (20 deg/s) it trips only past 44.4 deg. */
static void TheRangeTripsBeforeTheEndByTheSpeedAndTheStoppingDistance(void) {
  mfb_board_si si = rig_si();
  si.joints[0].range_vent = true;
  si.joints[0].angle_lead_s = 0.020;
  si.joints[0].brake_rad_per_s2 = 1000.0 * 3.141592653589793 / 180.0;
  power_on_with(&si);
  g_bench.in.encoder[0] = -8000; /* -41.1 deg, still */
  const uint16_t both[MFB_DA_CHANNELS] = {19661, 19661, 40000, 0, 0, 0, 0, 0};
  for (int k = 0; k < MFB_RATE_WINDOW; ++k) send(7, 0, both);
  arm(7, both);
  CHECK(mfb_board_outputs_live(&g_board));
  int fired_at = -1;
  int32_t counts = -8000;
  for (int k = 1; k <= 200 && fired_at < 0; ++k) {
    counts += 58; /* 298 deg/s */
    g_bench.in.encoder[0] = counts;
    send(7, MFB_COMMAND_ENABLE, both);
    if (g_bench.da[0] == kSafeValve) fired_at = k;
  }
  /* 58000 counts/s: a lead of 1160 counts and 58000^2 / (2 x 194444) = 8650 to stop: led past
   * 8750 once counts > -1060, the first at k = 120 (-1040, -5.3 deg) */
  CHECK_EQ(fired_at, 120);
  CHECK_EQ(g_bench.da[1], 19661); /* the antagonist brakes */
  CHECK_EQ(g_bench.da[2], kSafeMotor);
  /* An arming edge releases the range trip only once the joint is inside by 5 % of the span (875
   * counts, to 7875): at 41.1 deg (8000) it holds; at 40.1 deg (7800) it is released. */
  g_bench.in.encoder[0] = 8000;
  for (int k = 0; k < MFB_RATE_WINDOW; ++k) send(7, 0, both);
  send(7, MFB_COMMAND_ENABLE, both);
  CHECK_EQ(g_bench.da[0], kSafeValve);
  g_bench.in.encoder[0] = 7800;
  for (int k = 0; k < MFB_RATE_WINDOW; ++k) send(7, 0, both);
  send(7, MFB_COMMAND_ENABLE, both);
  CHECK_EQ(g_bench.da[0], 19661);
  /* slowly towards the end: 20 deg/s = 3.9 counts per period, from 40.1 deg held still */
  counts = 7800;
  fired_at = -1;
  for (int k = 0; k < 400 && fired_at < 0; ++k) {
    counts += (k % 10) < 9 ? 4 : 3; /* 39 counts per 10 ms: 20.06 deg/s */
    g_bench.in.encoder[0] = counts;
    send(7, MFB_COMMAND_ENABLE, both);
    if (g_bench.da[0] == kSafeValve) fired_at = counts;
  }
  /* 20 deg/s: 28 counts in the 7 ms window (4000 counts/s), a lead of 80 counts and 41 to stop:
   * led past 8750 once counts pass 8629 (44.38 deg) with 28 counts in the window, 8635 with 27; from
   * 7800 the first sample past either is 8639 */
  CHECK_EQ(fired_at, 8639);
}

/* The range margin is what the range judges: the led counts' distance inside the nearer end. With
 * 20 ms of lead and 1000 deg/s^2 of braking, still at -8000 counts it is 750 (to -8750); moving up
 * at 58000 counts/s it is 8750 - (counts + 1160 + 8650); past the end it is negative (the trip). */
static void TheRangeMarginIsTheLedAnglesDistanceInsideTheNearerEnd(void) {
  mfb_board_si si = rig_si();
  si.joints[0].range_vent = true;
  si.joints[0].angle_lead_s = 0.020;
  si.joints[0].brake_rad_per_s2 = 1000.0 * 3.141592653589793 / 180.0;
  power_on_with(&si);
  const uint16_t both[MFB_DA_CHANNELS] = {19661, 19661, 40000, 0, 0, 0, 0, 0};
  g_bench.in.encoder[0] = -8000;
  for (int k = 0; k < MFB_RATE_WINDOW; ++k) send(7, 0, both);
  CHECK_EQ(mfb_board_range_margin(&g_board, 0), 750);
  int32_t counts = -8000;
  for (int k = 0; k < MFB_RATE_WINDOW; ++k) {
    counts += 58;
    g_bench.in.encoder[0] = counts;
    send(7, 0, both);
  }
  CHECK_EQ(counts, -7536);
  CHECK_EQ(mfb_board_range_margin(&g_board, 0), 8750 - (-7536 + 1160 + 8650)); /* 6476: the upper end is nearer now */
  g_bench.in.encoder[0] = 8700; /* inside, but jumped there: its speed leads it far past 8750 */
  send(7, 0, both);
  CHECK(mfb_board_range_margin(&g_board, 0) < 0);
  CHECK_EQ(mfb_board_range_margin(&g_board, 1), INT32_MAX); /* no such joint */
  CHECK_EQ(mfb_board_range_margin(&g_board, -1), INT32_MAX);
}

/* The speed ceiling: 400 deg/s (77.8 counts per 1 ms period), no lead. Moving up at 78 counts per
 * period the joint passes it: its motor is cut and the agonist, which drives it that way, vented; the
 * antagonist keeps its command and brakes. Moving at 77 it does not trip. */
static void AJointOverItsSpeedCeilingCutsItsMotorAndVentsTheMuscleDrivingIt(void) {
  mfb_board_si si = rig_si();
  si.joints[0].speed_ceiling_rad_per_s = 400.0 * 3.141592653589793 / 180.0; /* 77777.8 counts/s */
  power_on_with(&si);
  const uint16_t torque[MFB_DA_CHANNELS] = {19661, 19661, 40000, 0, 0, 0, 0, 0};
  g_bench.in.encoder[0] = -8000; /* still there for a window before the edge */
  for (int k = 0; k < MFB_RATE_WINDOW; ++k) send(7, 0, torque);
  arm(7, torque);
  const uint64_t trips_before = mfb_board_counters(&g_board)->speed_trips; /* the jump to -8000 was one */
  int32_t counts = -8000;
  for (int k = 0; k < 3 * MFB_RATE_WINDOW; ++k) {
    counts += 77; /* 77000 counts/s: 396 deg/s */
    g_bench.in.encoder[0] = counts;
    send(7, MFB_COMMAND_ENABLE, torque);
  }
  CHECK_EQ(g_bench.da[0], 19661);
  CHECK_EQ(g_bench.da[2], 40000);
  CHECK_EQ(mfb_board_speed(&g_board, 0), 77000);
  for (int k = 0; k < MFB_RATE_WINDOW; ++k) {
    counts += 78;
    g_bench.in.encoder[0] = counts;
    send(7, MFB_COMMAND_ENABLE, torque);
  }
  CHECK_EQ(g_bench.da[0], kSafeValve);
  CHECK_EQ(g_bench.da[1], 19661); /* the antagonist brakes */
  CHECK_EQ(g_bench.da[2], kSafeMotor);
  CHECK_EQ(mfb_board_counters(&g_board)->speed_trips, trips_before + 1);
  CHECK_EQ(mfb_board_counters(&g_board)->range_trips, 0);
  uint8_t out[MFB_STATE_PACKET_SIZE];
  CHECK_EQ(mfb_board_state_packet(&g_board, out, sizeof out), MFB_STATE_PACKET_SIZE);
  CHECK_EQ(out[114], 0x01); /* joint 0's agonist */
  CHECK_EQ(out[116], 0x01); /* joint 0's motor */
  /* Latched: slower again, the agonist stays vented until an arming edge. */
  for (int k = 0; k < MFB_RATE_WINDOW; ++k) send(7, MFB_COMMAND_ENABLE, torque);
  CHECK_EQ(g_bench.da[0], kSafeValve);
}

/* The speed trip is latched per muscle: the joint flung back down past the ceiling has its
 * antagonist vented too, and the agonist does not refill (it would fling it up again). An arming
 * edge releases both together, once the joint is below half the ceiling (38889 counts/s): at 40000
 * counts/s they hold, at 38000 they are released. */
static void ASpeedTripHoldsBothWaysUntilAnEdgeFindsTheJointBelowHalfItsCeiling(void) {
  mfb_board_si si = rig_si();
  si.joints[0].speed_ceiling_rad_per_s = 400.0 * 3.141592653589793 / 180.0;
  power_on_with(&si);
  const uint16_t torque[MFB_DA_CHANNELS] = {19661, 19661, 40000, 0, 0, 0, 0, 0};
  arm(7, torque);
  int32_t counts = 0;
  for (int k = 0; k < MFB_RATE_WINDOW; ++k) {
    counts += 90;
    g_bench.in.encoder[0] = counts;
    send(7, MFB_COMMAND_ENABLE, torque);
  }
  CHECK_EQ(g_bench.da[0], kSafeValve);
  CHECK_EQ(g_bench.da[1], 19661);
  for (int k = 0; k < MFB_RATE_WINDOW; ++k) {
    counts -= 90;
    g_bench.in.encoder[0] = counts;
    send(7, MFB_COMMAND_ENABLE, torque);
  }
  CHECK_EQ(g_bench.da[0], kSafeValve);
  CHECK_EQ(g_bench.da[1], kSafeValve);
  CHECK_EQ(mfb_board_counters(&g_board)->speed_trips, 1); /* one joint's trip */
  for (int k = 0; k < MFB_RATE_WINDOW; ++k) {
    counts -= 40; /* 40000 counts/s: above half the ceiling */
    g_bench.in.encoder[0] = counts;
    send(7, 0, torque);
  }
  counts -= 40;
  g_bench.in.encoder[0] = counts;
  send(7, MFB_COMMAND_ENABLE, torque);
  CHECK(mfb_board_outputs_live(&g_board));
  CHECK_EQ(g_bench.da[0], kSafeValve);
  CHECK_EQ(g_bench.da[1], kSafeValve);
  CHECK_EQ(g_bench.da[2], kSafeMotor);
  for (int k = 0; k < MFB_RATE_WINDOW; ++k) {
    counts -= 38; /* 38000 counts/s: below half */
    g_bench.in.encoder[0] = counts;
    send(7, 0, torque);
  }
  counts -= 38;
  g_bench.in.encoder[0] = counts;
  send(7, MFB_COMMAND_ENABLE, torque);
  CHECK_EQ(g_bench.da[0], 19661);
  CHECK_EQ(g_bench.da[1], 19661);
  CHECK_EQ(g_bench.da[2], 40000);
}

/* The speed led by its acceleration over the valves' reaction: 50 ms of lead. A joint accelerating
 * from rest at 2 counts per period per period (2e6 counts/s^2, 10 286 deg/s^2) is judged about
 * 100 000 counts/s ahead of its speed, so it trips while still slow (the ceiling is 77 777
 * counts/s); without the lead only once its speed passes the ceiling, 37 periods later. */
static void TheSpeedTripLeadsTheSpeedByItsAccelerationTimesTheReaction(void) {
  for (int lead = 1; lead >= 0; --lead) {
    mfb_board_si si = rig_si();
    si.joints[0].speed_ceiling_rad_per_s = 400.0 * 3.141592653589793 / 180.0;
    si.joints[0].speed_lead_s = lead ? 0.050 : 0.0;
    power_on_with(&si);
    const uint16_t torque[MFB_DA_CHANNELS] = {19661, 19661, 40000, 0, 0, 0, 0, 0};
    arm(7, torque);
    int32_t counts = 0, step = 0;
    int fired_at = -1;
    for (int k = 1; k <= 100 && fired_at < 0; ++k) {
      step += 2;
      counts += step;
      g_bench.in.encoder[0] = counts;
      send(7, MFB_COMMAND_ENABLE, torque);
      if (g_bench.da[0] == kSafeValve) fired_at = k;
    }
    /* With the lead: at k = 5 the window holds counts 0, 0, 0, 2, 6, 12, 20, 30 over 7 ms (4285
     * counts/s); its halves, 0..2 over 3 ms and 2..30 over 4 ms (666 and 7000 counts/s), differ by
     * 6333 over half the window: 4285 + 6333 x 50 / 3.5 = 94 770 > 77 777 (at k = 4: 59 427).
     * Without: the window's mean speed passes 77 777 at k = 42 (78 000: the steps 72..84). */
    CHECK_EQ(fired_at, lead ? 5 : 42);
    CHECK_EQ(g_bench.da[1], 19661);
  }
  /* At a steady speed the lead adds nothing: 77 counts per period, a whole window, 77 000 counts/s. */
  mfb_board_si steady = rig_si();
  steady.joints[0].speed_ceiling_rad_per_s = 400.0 * 3.141592653589793 / 180.0;
  steady.joints[0].speed_lead_s = 0.050;
  power_on_with(&steady);
  for (int32_t k = 1, counts = 0; k <= 2 * MFB_RATE_WINDOW; ++k) {
    counts += 77;
    g_bench.in.encoder[0] = counts;
    send(7, 0, kHalfBar);
  }
  CHECK_EQ(mfb_board_speed(&g_board, 0), 77000);
  mfb_board_si si = rig_si();
  mfb_board_config cfg;
  char error[200];
  si.joints[0].speed_ceiling_rad_per_s = -1.0;
  CHECK(!mfb_configure(&si, &cfg, error, sizeof error));
  CHECK(strstr(error, "joints[0].speed_ceiling_rad_per_s") != NULL);
  si = rig_si();
  si.joints[0].speed_ceiling_rad_per_s = 1.0;
  si.joints[0].speed_lead_s = 2.0;
  CHECK(!mfb_configure(&si, &cfg, error, sizeof error));
  CHECK(strstr(error, "joints[0].speed_lead_s") != NULL);
  si = rig_si();
  si.joints[0].speed_ceiling_rad_per_s = 1.0;
  si.joints[0].encoder.channel = -1;
  CHECK(!mfb_configure(&si, &cfg, error, sizeof error));
  CHECK(strstr(error, "without an encoder") != NULL);
}

/* 2 MPa/s on a 0..1 MPa valve: 131.07 codes per 1 ms period (8589 / 65536 codes per us). A step to
 * the top rises along it to the 0.8 MPa ceiling in 401 ms; a fall is at once; the motor is not slewed. */
static void TheSlewLimitHoldsAValveStepToItsRate(void) {
  mfb_board_si si = rig_si();
  si.joints[0].muscle[0].pressure_rise_Pa_per_s = 2e6;
  si.joints[0].muscle[1].pressure_rise_Pa_per_s = 2e6;
  power_on_with(&si);
  arm(7, kEverythingMax); /* the edge's period: 1 ms of rise */
  CHECK_EQ(g_bench.da[0], 131);
  CHECK_EQ(g_bench.da[1], 131);
  CHECK_EQ(g_bench.da[2], 60074);
  for (int k = 0; k < 9; ++k) send(7, MFB_COMMAND_ENABLE, kEverythingMax);
  CHECK_EQ(g_bench.da[0], 1310); /* 10 ms: 8589 * 10000 / 65536 = 1310.6, the fraction kept */
  for (int k = 0; k < 390; ++k) send(7, MFB_COMMAND_ENABLE, kEverythingMax);
  CHECK_EQ(g_bench.da[0], 52423); /* 400 ms: 8589 * 400000 / 65536 = 52423.8, short of the ceiling */
  send(7, MFB_COMMAND_ENABLE, kEverythingMax);
  CHECK_EQ(g_bench.da[0], 52428); /* 401 ms: the ceiling */
  const uint16_t low[MFB_DA_CHANNELS] = {1000, 1000, 32768, 0, 0, 0, 0, 0};
  send(7, MFB_COMMAND_ENABLE, low);
  CHECK_EQ(g_bench.da[0], 1000);
  send(7, MFB_COMMAND_ENABLE, kEverythingMax); /* and rises again from there */
  CHECK_EQ(g_bench.da[0], 1131);
  CHECK(mfb_board_counters(&g_board)->slewed > 800);
}

/* A lead of 20 ms on a force rising 10 N per period (131 codes, 10 kN/s): the trip fires when the
 * force plus 200 N passes 2000 N, i.e. at the first sample above 1800 N, not at 2000 N. */
static void TheForceTripLeadsTheForceByItsRateTimesTheReaction(void) {
  mfb_board_si si = rig_si();
  si.joints[0].muscle[0].force_lead_s = 0.020;
  power_on_with(&si);
  g_bench.in.ad[0] = 22282; /* 1700 N from power-on (a jump would trip it), held a whole rate window: no rate, no lead */
  mfb_board_init(&g_board, &g_cfg, &g_hal);
  for (int k = 0; k < MFB_RATE_WINDOW; ++k) send(7, 0, kHalfBar);
  arm(7, kHalfBar);
  for (int k = 0; k < 10; ++k) send(7, MFB_COMMAND_ENABLE, kHalfBar);
  CHECK_EQ(g_bench.da[0], 19661);
  const uint64_t trips_before = mfb_board_counters(&g_board)->force_trips;
  int fired_at = -1;
  for (int k = 1; k <= 20 && fired_at < 0; ++k) {
    g_bench.in.ad[0] = (uint16_t)(22282 + 131 * k);
    send(7, MFB_COMMAND_ENABLE, kHalfBar);
    if (g_bench.da[0] == kSafeValve) fired_at = k;
  }
  CHECK_EQ(fired_at, 11); /* 23723 = 1810 N measured; at k = 10 (1800 N) 23592 + 2620 < 26214 */
  CHECK_EQ(mfb_board_counters(&g_board)->force_trips, trips_before + 1);
  g_bench.in.ad[0] = 26000; /* 1984 N, steady: under the ceiling, but a trip is released only below half of it */
  for (int k = 0; k < MFB_RATE_WINDOW; ++k) send(7, 0, kHalfBar);
  send(7, MFB_COMMAND_ENABLE, kHalfBar);
  CHECK_EQ(g_bench.da[0], kSafeValve);
}

static void ConfigureNamesTheFieldAndWhatItFound(void) {
  mfb_board_si si = rig_si();
  mfb_board_config cfg;
  char error[200];
  si.joints[0].muscle[1].force_ceiling_N = 1500; /* beyond the 0..1000 N load cell */
  CHECK(!mfb_configure(&si, &cfg, error, sizeof error));
  CHECK(strstr(error, "joints[0].antagonist.force_ceiling_N") != NULL);
  CHECK(strstr(error, "found 1500") != NULL);
  si = rig_si();
  si.joints[0].motor.channel = 0; /* the agonist valve's channel */
  CHECK(!mfb_configure(&si, &cfg, error, sizeof error));
  CHECK(strstr(error, "motor: DA channel used twice") != NULL);
  si = rig_si();
  si.joints[0].muscle[0].pressure_ceiling_Pa = 2e6; /* above the valve's 1 MPa at code 65535: clamped to the top code */
  CHECK(mfb_configure(&si, &cfg, error, sizeof error));
  CHECK_EQ(cfg.da_max[0], 65535);
  si.safe_da[0] = 60000; /* a "safe" valve code at 0.92 MPa: not a vent */
  si.joints[0].muscle[0].pressure_ceiling_Pa = 0.8e6;
  CHECK(!mfb_configure(&si, &cfg, error, sizeof error));
  CHECK(strstr(error, "found 60000") != NULL);
}

/* ---- cost ------------------------------------------------------------------------------------------ */

static void OnePacketsCost(void) {
  power_on();
  arm(7, kHalfBar);
  enum { kPackets = 200 };
  const uint64_t start = test_ticks();
  for (int k = 0; k < kPackets; ++k) {
    mfb_command c;
    memset(&c, 0, sizeof c);
    c.type = MFB_TYPE_COMMAND;
    c.session_id = 7;
    c.sequence = ++g_sequence;
    memcpy(c.da, kHalfBar, sizeof c.da);
    c.flags = MFB_COMMAND_ENABLE;
    c.board_nonce = g_nonce;
    uint8_t in[MFB_COMMAND_PACKET_SIZE], out[MFB_STATE_PACKET_SIZE];
    mfb_encode_command(&c, g_cfg.key, test_mac, NULL, in, sizeof in); /* the host's half, subtracted below */
    mfb_board_receive(&g_board, in, sizeof in, kHost, NULL);
    mfb_board_sample(&g_board);
    mfb_board_drive(&g_board);
    mfb_board_poll(&g_board);
    mfb_board_state_packet(&g_board, out, sizeof out);
  }
  const uint64_t total = test_ticks() - start;
  const uint64_t host_start = test_ticks();
  for (int k = 0; k < kPackets; ++k) {
    mfb_command c;
    memset(&c, 0, sizeof c);
    c.type = MFB_TYPE_COMMAND;
    c.sequence = (uint32_t)k;
    uint8_t in[MFB_COMMAND_PACKET_SIZE];
    mfb_encode_command(&c, g_cfg.key, test_mac, NULL, in, sizeof in);
  }
  const uint64_t host = test_ticks() - host_start;
  /* A report, not a check (costs are the benchmarks' to judge): on a loaded host machine the
   * host's half alone can take longer than both, and the difference means nothing then. */
  test_report_cost("board period (receive, sample, drive, poll, state packet)", total > host ? (total - host) / kPackets : 0);
  const uint64_t mac_start = test_ticks();
  uint8_t mac[MFB_MAC_SIZE];
  for (int k = 0; k < kPackets; ++k) test_mac(NULL, g_cfg.key, kGoldenState, MFB_STATE_PACKET_SIZE - MFB_MAC_SIZE, mac);
  test_report_cost("one MAC of a state packet (121 bytes)", (test_ticks() - mac_start) / kPackets);
}

int main(void) {
  test_platform_init();
  run(Crc32cHasTheCastagnoliCheckValue, "Crc32cHasTheCastagnoliCheckValue");
  run(GoldenCommandDecodesWithItsPythonMac, "GoldenCommandDecodesWithItsPythonMac");
  run(GoldenStateEncodesToItsBytes, "GoldenStateEncodesToItsBytes");
  run(ChecksRunInTheProtocolsOrder, "ChecksRunInTheProtocolsOrder");
  run(NothingIsSentAndOutputsAreSafeBeforeTheFirstSession, "NothingIsSentAndOutputsAreSafeBeforeTheFirstSession");
  run(AnEnableEdgeOfTheSessionArmsTheOutputs, "AnEnableEdgeOfTheSessionArmsTheOutputs");
  run(ARecordedSessionReplayedToARebootedBoardIsRefused, "ARecordedSessionReplayedToARebootedBoardIsRefused");
  run(ARecordedSessionReplayedToTheSameBootLaterIsRefused, "ARecordedSessionReplayedToTheSameBootLaterIsRefused");
  run(AReplayedArmingDoesNotArm, "AReplayedArmingDoesNotArm");
  run(ASecondSourceWithTheKeyCannotSpeakForTheSession, "ASecondSourceWithTheKeyCannotSpeakForTheSession");
  run(TheBoardNonceIsFreshPerBootAndPerSession, "TheBoardNonceIsFreshPerBootAndPerSession");
  run(AHelloDrivesNothingAndLeavesTheSessionAlone, "AHelloDrivesNothingAndLeavesTheSessionAlone");
  run(TheSessionBelongsToItsEndpointAndSequenceOnlyMovesForward, "TheSessionBelongsToItsEndpointAndSequenceOnlyMovesForward");
  run(TheWatchdogCutsTheMotorAndVentsAlongTheRamp, "TheWatchdogCutsTheMotorAndVentsAlongTheRamp");
  run(AfterAHostLossOnlyTheOperatorsArmingArms, "AfterAHostLossOnlyTheOperatorsArmingArms");
  run(AnEstopDisarmsAndTheEdgeMustFollowItsRelease, "AnEstopDisarmsAndTheEdgeMustFollowItsRelease");
  run(AHijackingHostGetsNoMoreThanTheCeilings, "AHijackingHostGetsNoMoreThanTheCeilings");
  run(ALoadCellOverItsCeilingVentsThatMuscleOnly, "ALoadCellOverItsCeilingVentsThatMuscleOnly");
  run(ATripSurvivesAnEdgeWhileItsCauseRemains, "ATripSurvivesAnEdgeWhileItsCauseRemains");
  run(AnEdgeReleasesAForceTripOnlyBelowHalfItsCeiling, "AnEdgeReleasesAForceTripOnlyBelowHalfItsCeiling");
  run(AJointsTrippedMusclesAreReleasedTogether, "AJointsTrippedMusclesAreReleasedTogether");
  run(AForceTripThatHoldsKeepsItsJointsRangeTrip, "AForceTripThatHoldsKeepsItsJointsRangeTrip");
  run(ARangeTripReleasesTheForceTripOfTheMuscleThatBrakes, "ARangeTripReleasesTheForceTripOfTheMuscleThatBrakes");
  run(AJointOutOfRangeTurnsItsMotorOffAndKeepsTheMuscles, "AJointOutOfRangeTurnsItsMotorOffAndKeepsTheMuscles");
  run(AJointOutOfRangeCutsItsMotorAndVentsTheMuscleDrivingItOut, "AJointOutOfRangeCutsItsMotorAndVentsTheMuscleDrivingItOut");
  run(TheProcedureKeyKeepsTheMusclesOutsideTheRangeAndStillCutsTheMotor, "TheProcedureKeyKeepsTheMusclesOutsideTheRangeAndStillCutsTheMotor");
  run(TheStatePacketTellsTheHostWhichMusclesAndMotorsTheLimitsCut, "TheStatePacketTellsTheHostWhichMusclesAndMotorsTheLimitsCut");
  run(TheRangeTripsBeforeTheEndByTheSpeedAndTheStoppingDistance, "TheRangeTripsBeforeTheEndByTheSpeedAndTheStoppingDistance");
  run(TheRangeMarginIsTheLedAnglesDistanceInsideTheNearerEnd, "TheRangeMarginIsTheLedAnglesDistanceInsideTheNearerEnd");
  run(AJointOverItsSpeedCeilingCutsItsMotorAndVentsTheMuscleDrivingIt, "AJointOverItsSpeedCeilingCutsItsMotorAndVentsTheMuscleDrivingIt");
  run(ASpeedTripHoldsBothWaysUntilAnEdgeFindsTheJointBelowHalfItsCeiling, "ASpeedTripHoldsBothWaysUntilAnEdgeFindsTheJointBelowHalfItsCeiling");
  run(TheSpeedTripLeadsTheSpeedByItsAccelerationTimesTheReaction, "TheSpeedTripLeadsTheSpeedByItsAccelerationTimesTheReaction");
  run(TheSlewLimitHoldsAValveStepToItsRate, "TheSlewLimitHoldsAValveStepToItsRate");
  run(TheForceTripLeadsTheForceByItsRateTimesTheReaction, "TheForceTripLeadsTheForceByItsRateTimesTheReaction");
  run(ConfigureNamesTheFieldAndWhatItFound, "ConfigureNamesTheFieldAndWhatItFound");
  run(OnePacketsCost, "OnePacketsCost");
  printf("firmware core tests: %d run, %d failed (%d checks)\n", g_tests, g_failed_tests, g_failed_checks);
  return test_platform_exit(g_failed_tests);
}
