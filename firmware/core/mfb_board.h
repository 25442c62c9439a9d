/* The board core: everything the multifunction board (MFB) decides, written once for every board
 * (docs/porting.md). Freestanding C11, no heap, no OS: it reaches the hardware only through
 * `mfb_hal`, and its configuration is a plain struct made once at set-up (`mfb_configure`).
 *
 * What it does, per datagram and per board period:
 * - packet checks (size, magic, version, type, length, CRC-32C, MAC through the HAL, flags,
 *   session != 0), the handshake (a hello is answered with the board's nonce for that host nonce
 *   and endpoint; only a command carrying it opens a session, so a recording of an earlier session
 *   never does), the session (one host endpoint, newest-only sequence), arming (an enable edge of
 *   the session; operator arming after a host loss), the watchdog and the safe outputs (motors cut
 *   at once, valves vented along a ramp over `vent_us`);
 * - hard limits of its own, independent of the host: every DA code clamped to its channel's
 *   ceiling (valve pressure, motor torque); each valve's setpoint rises no faster than its slew
 *   limit; a load cell whose force, led by its rate over the valve's reaction time, passes its
 *   ceiling vents that muscle; a joint outside its range turns its motor off, and where the range
 *   vents (`range_vent`) a joint whose angle, led by its speed over the valves' reaction time plus
 *   the distance the other muscle needs to stop it, passes an end of its range also has the muscle
 *   driving it out vented (the other keeps its command: it brakes and holds the limb), unless the
 *   rig's procedure key (a physical input) is turned; where the speed vents (`speed_vent`) a joint
 *   whose speed, led by its acceleration over the valves' reaction time, passes its ceiling has its
 *   motor cut and the muscle driving it that way vented (a swing back vents the other one too). The
 *   trips latch until an arming edge finds the joint back inside (slower than half its speed
 *   ceiling) and the load cell below half its ceiling, a joint's trips together (one muscle
 *   released while the other still vents would swing the limb); while the range vents or the
 *   speed trips, the muscle that brakes is released from a force trip of its own as soon as its
 *   load cell is below half its ceiling. No packet can change the limits.
 *
 * The rules are those of docs/mfb-protocol.md (the host's side: include/peha/mfb/protocol.hpp).
 * Every function here is O(1), allocates nothing and never blocks. */
#ifndef PEHA_FIRMWARE_MFB_BOARD_H
#define PEHA_FIRMWARE_MFB_BOARD_H

#include "mfb_wire.h"

#ifdef __cplusplus
extern "C" {
#endif

#define MFB_MAX_JOINTS 8
#define MFB_AGONIST 0 /* drives the joint's angle up (docs/models.md: positive in its direction) */
#define MFB_ANTAGONIST 1
/* Samples over which a load cell's rate and a joint's speed (and its change) are measured for the trips: 8
 * board periods (8 ms), long enough that 1 N of load-cell noise leads the force by less than 10 N. */
#define MFB_RATE_WINDOW 8
/* A force trip is released (at an arming edge, or for the muscle a range trip needs as its brake)
 * only once the load cell is below this fraction of its ceiling: refilled from nearer the ceiling,
 * the valve's dead time and lag carry the force past it before the trip's lead sees it rise. */
#define MFB_RELEASE_FRACTION 0.5
/* A joint's range trip is released at an arming edge only once its led angle is inside the range
 * by this fraction of the range's span (hysteresis: docs/safety.md "The board's own limits"). */
#define MFB_RANGE_RELEASE_FRACTION 0.05
/* A joint's speed trip is released at an arming edge only once its speed is below this fraction of
 * its ceiling: released while it still flies, the muscle it vented drives it on at once. */
#define MFB_SPEED_RELEASE_FRACTION 0.5

/* ---- the HAL: what a board provides (docs/porting.md) ---------------------------------------- */

/* One sample of every input, taken together. */
typedef struct mfb_inputs {
  uint16_t ad[MFB_AD_CHANNELS];
  int32_t encoder[MFB_ENCODER_CHANNELS];
  uint8_t digital_in;
  uint64_t time_ns; /* board clock when sampled (reported to the host) */
} mfb_inputs;

typedef struct mfb_hal {
  void* ctx; /* passed to every call */
  /* Samples the AD channels, encoder counters and digital input lines. */
  void (*read_inputs)(void* ctx, mfb_inputs* out);
  /* Drives the DA channels and digital output lines. */
  void (*write_outputs)(void* ctx, const uint16_t da[MFB_DA_CHANNELS], uint8_t digital_out);
  /* A monotonic microsecond clock (the watchdog and the vent ramp). */
  uint64_t (*now_us)(void* ctx);
  /* Keyed BLAKE2b-128 (RFC 7693) from a vetted library: libsodium, the BLAKE2 reference code. */
  mfb_mac_fn mac;
  /* A 32-bit random number from a hardware TRNG or the OS's entropy source: the boot id and the
   * boot secret from which every session's board nonce is derived (docs/porting.md). A predictable
   * source makes recorded sessions replayable. */
  uint32_t (*random_u32)(void* ctx);
} mfb_hal;

/* ---- configuration: what the board is told once, in SI, and keeps as codes --------------------- */

/* A linear AD or DA channel: value_SI = offset_SI + scale_SI * code. channel -1: not mapped. */
typedef struct mfb_channel_si {
  int channel;
  double offset_SI;
  double scale_SI;
} mfb_channel_si;

/* An encoder: angle_rad = offset_rad + rad_per_count * counts. channel -1: none. */
typedef struct mfb_encoder_si {
  int channel;
  double offset_rad;
  double rad_per_count;
} mfb_encoder_si;

typedef struct mfb_muscle_si {
  mfb_channel_si valve;         /* DA, Pa */
  mfb_channel_si loadcell;      /* AD, N */
  double pressure_ceiling_Pa;   /* the valve's setpoint never exceeds this */
  double force_ceiling_N;       /* the load cell above this vents the muscle */
  double pressure_rise_Pa_per_s; /* the valve's setpoint rises no faster (falls freely) */
  double force_lead_s;          /* the trip judges force + rate x this: the valve's reaction time */
} mfb_muscle_si;

typedef struct mfb_joint_si {
  mfb_muscle_si muscle[2];      /* MFB_AGONIST, MFB_ANTAGONIST */
  mfb_channel_si motor;         /* DA, torque at the joint in Nm; channel -1: no motor */
  double motor_ceiling_Nm;      /* |torque| the driver is never asked for more than */
  mfb_encoder_si encoder;
  double min_angle_rad, max_angle_rad; /* outside: the motor is off */
  bool range_vent;              /* and the muscle driving it out is vented, judged on the angle ... */
  double angle_lead_s;          /* ... + speed x this (the valves' reaction) ... */
  double brake_rad_per_s2;      /* ... + speed^2 / (2 x this): the deceleration the other muscle gives */
  /* A joint whose speed, led by its acceleration x `speed_lead_s` (the valves' reaction), passes
   * this has its motor cut and the muscle driving it that way vented, the other kept (0: none). */
  double speed_ceiling_rad_per_s;
  double speed_lead_s;
} mfb_joint_si;

typedef struct mfb_board_si {
  uint8_t key[MFB_KEY_SIZE];
  double watchdog_s;            /* no accepted command this long -> safe outputs */
  double vent_s;                /* the valves' ramp to their safe codes after disarming */
  uint16_t safe_da[MFB_DA_CHANNELS]; /* vent / zero-torque codes */
  uint8_t safe_digital_out;
  int estop_line;               /* 0..7 */
  bool estop_active_high;
  /* The procedure key (-1: none): a key switch at the rig, turned by a person for a procedure that
   * drives joints onto their stops on purpose (the calibration recording). While its input is
   * active the range does not vent (the motor cut outside the range stays); no packet can set it. */
  int procedure_key_line;       /* -1 or 0..7, not the e-stop's */
  bool procedure_key_active_high;
  int joint_count;
  mfb_joint_si joints[MFB_MAX_JOINTS];
} mfb_board_si;

typedef struct mfb_muscle_limit {
  int8_t valve_da;              /* -1: none */
  int8_t loadcell_ad;           /* -1: none */
  bool trip_above;              /* the force rises with the code (false: falls) */
  uint16_t trip_code;           /* the code of the force ceiling */
  uint16_t release_code;        /* the code of half the ceiling: a trip is released only below it */
  uint32_t lead_us;             /* the trip's lead (0: the measured force alone) */
} mfb_muscle_limit;

typedef struct mfb_joint_limit {
  mfb_muscle_limit muscle[2];
  int8_t motor_da;              /* -1: none */
  int8_t encoder;               /* -1: no range check */
  int32_t min_counts, max_counts;
  bool counts_rise_with_angle;  /* max_counts is the max_angle_rad side */
  bool range_vent;              /* out of range also vents the muscle driving it out (else: motor only) */
  uint32_t angle_lead_us;       /* the range's lead for the speed (0: none) */
  uint32_t brake_counts_per_s2; /* the stopping distance's deceleration (0: no stopping distance) */
  uint32_t speed_ceiling_counts_per_s; /* faster (led): the speed trip (0: none; needs the encoder) */
  uint32_t speed_lead_us;       /* the speed trip's lead for the acceleration (0: the speed alone) */
} mfb_joint_limit;

/* The board's configuration in codes: what the loop reads. Immutable once made. */
typedef struct mfb_board_config {
  uint8_t key[MFB_KEY_SIZE];
  uint32_t watchdog_us;
  uint32_t vent_us;
  uint16_t safe_da[MFB_DA_CHANNELS];
  uint8_t safe_digital_out;
  uint16_t da_min[MFB_DA_CHANNELS]; /* every DA code is clamped into [da_min, da_max] */
  uint16_t da_max[MFB_DA_CHANNELS];
  /* The slew limit: how far a valve's code may move towards more pressure per microsecond, in
   * 1/65536 codes (0: the channel is not slew-limited), and that direction (bit i: up the codes). */
  uint32_t da_rise_q16_per_us[MFB_DA_CHANNELS];
  uint8_t da_rise_up;
  uint8_t estop_line;
  bool estop_active_high;
  int8_t procedure_key_line;    /* -1: none */
  bool procedure_key_active_high;
  uint8_t joint_count;
  mfb_joint_limit joints[MFB_MAX_JOINTS];
} mfb_board_config;

/* Set-up: checks `si` whole and converts it to codes. Returns true on success; otherwise writes
 * "field: expected ..., found ..." into `error` (at most `error_size` bytes, NUL-terminated) and
 * leaves `out` in an unspecified state. */
bool mfb_configure(const mfb_board_si* si, mfb_board_config* out, char* error, size_t error_size);

/* The nearest code to `value_SI` whose value does not pass it in `direction` (+1: not above, -1:
 * not below), within 0..65535; -1 if there is none. */
long mfb_code_within(const mfb_channel_si* ch, double value_SI, int direction);

/* ---- the board -------------------------------------------------------------------------------- */

typedef enum mfb_verdict {
  MFB_ACCEPT = 0,
  MFB_FOREIGN_SOURCE,
  MFB_FOREIGN_SESSION,
  MFB_DUPLICATE,
  MFB_STALE,
  MFB_MALFORMED,
  MFB_UNAUTHENTICATED,
  MFB_UNKNOWN_SESSION, /* a command of a session no handshake of this boot opened: a replay, or a
                        * host the board does not know (after a restart); answered with nonce 0 */
  MFB_HELLO            /* a hello: answered with the board's nonce, no session changed */
} mfb_verdict;

typedef struct mfb_counters {
  uint64_t accepted, foreign_source, foreign_session, duplicate, stale, malformed, unauthenticated;
  uint64_t unknown_session; /* commands of no session this boot's handshakes opened (replays) */
  uint64_t hellos;          /* hellos answered */
  uint64_t gaps;        /* sequence numbers skipped between accepted commands */
  uint64_t force_trips; /* muscles vented by their load cell's ceiling */
  uint64_t range_trips; /* joints (about to be) out of range: motor cut, the muscle driving out vented */
  uint64_t speed_trips; /* joints (about to be) over their speed ceiling: motor cut, the muscle driving them vented */
  uint64_t clamped;     /* DA codes the ceilings clamped */
  uint64_t slewed;      /* DA codes the slew limit held back */
} mfb_counters;

typedef struct mfb_endpoint {
  uint32_t address; /* IPv4, host byte order */
  uint16_t port;
} mfb_endpoint;

/* What a received datagram did. */
typedef enum mfb_event {
  MFB_EVENT_DROPPED = 0,   /* not accepted (see the verdict) */
  MFB_EVENT_COMMAND,       /* a command of the session held: drive the outputs with it */
  MFB_EVENT_NEW_SESSION,   /* a new session was adopted: outputs safe until its enable edge */
  MFB_EVENT_ANSWER         /* a hello or an unknown session: send mfb_board_answer_packet to its sender */
} mfb_event;

/* The watchdog's report. */
typedef enum mfb_watchdog {
  MFB_WATCHDOG_QUIET = 0,
  MFB_WATCHDOG_TRIPPED,        /* fired while the outputs were safe */
  MFB_WATCHDOG_HOST_LOST       /* fired while the outputs followed a host: it is gone */
} mfb_watchdog;

/* The board's state. Every field is private to mfb_board.c; read it through the functions. */
typedef struct mfb_board {
  const mfb_board_config* cfg;
  const mfb_hal* hal;
  uint32_t boot_id;
  uint8_t boot_secret[MFB_KEY_SIZE]; /* drawn at power-on: the board nonces of this boot */
  uint32_t epoch;                    /* +1 per session opened: every earlier nonce answered is void */
  /* session (the command filter): the host's nonce `session_id` and the board's `board_nonce` */
  bool has_session, ever_adopted, have_last;
  uint32_t session_id, last_sequence;
  uint64_t board_nonce;
  mfb_endpoint peer;
  /* the answer to the last hello or unknown session */
  mfb_endpoint answer_to;
  mfb_command answer_for;
  uint64_t answer_nonce;
  mfb_counters counters;
  mfb_parse_error last_error;
  /* arming: the session (its board nonce) whose edge is being made */
  uint64_t arm_nonce;
  bool seen_disable, armed, tripped, estop, host_lost;
  bool key_at_arming; /* the procedure key was turned at the arming edge (and the board is armed) */
  /* the command and what the outputs hold */
  mfb_command command;
  uint64_t last_command_us;
  uint16_t applied_da[MFB_DA_CHANNELS];
  uint8_t applied_digital;
  bool live, venting; /* live: the outputs followed the command last period */
  uint16_t vent_from_da[MFB_DA_CHANNELS];
  uint64_t vent_from_us;
  /* the slew limit: where each DA code may rise from, in 1/65536 codes, and the sample clock of
   * the last drive (the valve's time: on the emulator the plant's, not the host's) */
  uint32_t slew_q16[MFB_DA_CHANNELS];
  uint64_t drive_time_ns;
  /* the newest sample, the recent load-cell codes and encoder counts (rates), the limits' latches */
  mfb_inputs inputs;
  uint16_t history_ad[MFB_RATE_WINDOW][2 * MFB_MAX_JOINTS];
  int32_t history_counts[MFB_RATE_WINDOW][MFB_MAX_JOINTS];
  uint64_t history_ns[MFB_RATE_WINDOW];
  uint8_t history_next, history_count;
  uint16_t vented_muscles; /* bit 2*joint + muscle */
  uint8_t motors_off;      /* bit joint: (about to be) out of range */
  uint8_t out_high;        /* bit joint: out above max_angle_rad (else below min) */
  uint16_t speed_vented;   /* bit 2*joint + muscle: vented by its joint's speed ceiling (latched) */
  uint32_t state_sequence;
} mfb_board;

/* Power-on: no session, disarmed, safe outputs written, a fresh boot id and boot secret, one sample taken. */
void mfb_board_init(mfb_board* b, const mfb_board_config* cfg, const mfb_hal* hal);

/* One datagram from `from`: checks it, judges it against the session, and on acceptance updates
 * the arming and keeps the command (the caller then calls mfb_board_drive). A hello, and a command
 * of a session the board does not know while it holds none, return MFB_EVENT_ANSWER: the caller
 * sends mfb_board_answer_packet. */
mfb_event mfb_board_receive(mfb_board* b, const uint8_t* datagram, size_t size, mfb_endpoint from, mfb_verdict* verdict);

/* Samples every input through the HAL and checks the force ceilings (led by the force's rate), the
 * joint ranges (led by the speed and the stopping distance) and the speed ceilings (led by the
 * acceleration), latching. */
void mfb_board_sample(mfb_board* b);

/* Drives the outputs for this period from the newest sample and command: the command within the
 * ceilings, the slew limit and the trips while armed, otherwise the safe outputs (valves along the
 * vent ramp). The slew limit runs on the sample clock (mfb_inputs.time_ns): call once per sample. */
void mfb_board_drive(mfb_board* b);

/* The watchdog: call at least once per board period. */
mfb_watchdog mfb_board_poll(mfb_board* b);

/* The state packet of the newest sample (sequence +1), CRC and MAC included; 0 before the first
 * adopted session (there is nobody to send to) or if `capacity` < MFB_STATE_PACKET_SIZE. */
size_t mfb_board_state_packet(mfb_board* b, uint8_t* out, size_t capacity);

/* The answer to the datagram that returned MFB_EVENT_ANSWER: a state packet of the asking host
 * nonce (sequence +1), acknowledging its sequence, carrying the board nonce of that host nonce and
 * endpoint (a hello) or 0 (a session the board does not know), with kStatusNoSession. Writes the
 * destination into `to`; 0 if `capacity` < MFB_STATE_PACKET_SIZE. */
size_t mfb_board_answer_packet(mfb_board* b, uint8_t* out, size_t capacity, mfb_endpoint* to);

/* Readers. */
static inline bool mfb_board_outputs_live(const mfb_board* b) { return b->armed && !b->estop; }
static inline bool mfb_board_has_session(const mfb_board* b) { return b->has_session; }
static inline uint32_t mfb_board_session(const mfb_board* b) { return b->session_id; }
static inline mfb_endpoint mfb_board_peer(const mfb_board* b) { return b->peer; }
static inline uint32_t mfb_board_boot_id(const mfb_board* b) { return b->boot_id; }
static inline uint64_t mfb_board_nonce(const mfb_board* b) { return b->board_nonce; }
static inline bool mfb_board_estop(const mfb_board* b) { return b->estop; }
static inline const mfb_counters* mfb_board_counters(const mfb_board* b) { return &b->counters; }
static inline mfb_parse_error mfb_board_last_error(const mfb_board* b) { return b->last_error; }
static inline const uint16_t* mfb_board_applied_da(const mfb_board* b) { return b->applied_da; }
static inline uint8_t mfb_board_applied_digital(const mfb_board* b) { return b->applied_digital; }
static inline const mfb_inputs* mfb_board_inputs(const mfb_board* b) { return &b->inputs; }
/* How far joint `joint`'s angle, led as its range judges it (the speed x the lead + the stopping
 * distance), is inside the nearer end of its range, in encoder counts of the newest sample:
 * negative outside (a trip); INT32_MAX for a joint without a range. A commissioning figure: how
 * close a legitimate run came to the range's vent. */
int32_t mfb_board_range_margin(const mfb_board* b, int joint);
/* Joint `joint`'s speed as its speed ceiling judges it: over the rate window, led by the change of
 * speed between the window's halves x `speed_lead_s`, in encoder counts per second of the newest
 * sample (0 before the window has two samples, or without an encoder). A commissioning figure: how
 * close a legitimate run came to the ceiling. */
int32_t mfb_board_speed(const mfb_board* b, int joint);
/* The status bits of the next state packet. */
uint8_t mfb_board_status(const mfb_board* b);

#ifdef __cplusplus
}
#endif

#endif
