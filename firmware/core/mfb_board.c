#include "mfb_board.h"

#include <math.h>
#include <stdio.h> /* snprintf, set-up errors only */

/* ---- set-up ------------------------------------------------------------------------------------ */

long mfb_code_within(const mfb_channel_si* ch, double value_SI, int direction) {
  const double c = (value_SI - ch->offset_SI) / ch->scale_SI;
  /* The value grows with the code when the scale is positive: "not above the value" is then the
   * code below it. A hair of tolerance keeps an exact code (0 Nm at 32768) exact. */
  const bool down = (direction > 0) == (ch->scale_SI > 0);
  double code = down ? floor(c + 1e-9) : ceil(c - 1e-9);
  if (code < 0) code = down ? -1 : 0;
  if (code > 65535) code = down ? 65535 : -1;
  return (long)code;
}

/* "joints[0].agonist.force_ceiling_N: expected ..., found 2500": the field, what it must be, what it is. */
static bool fail(char* error, size_t size, int joint, const char* muscle, const char* what, double found) {
  if (error != NULL && size > 0) {
    snprintf(error, size, "joints[%d]%s%s.%s, found %g", joint, muscle[0] ? "." : "", muscle, what, found);
  }
  return false;
}

static bool good_channel(const mfb_channel_si* ch, int count) {
  return ch->channel < count && isfinite(ch->offset_SI) && isfinite(ch->scale_SI) && ch->scale_SI != 0;
}

/* The codes of [lo_SI, hi_SI] on `ch` into [*lo, *hi]; false if no code lies inside. */
static bool code_range(const mfb_channel_si* ch, double lo_SI, double hi_SI, uint16_t* lo, uint16_t* hi) {
  const long a = mfb_code_within(ch, lo_SI, -1);
  const long b = mfb_code_within(ch, hi_SI, +1);
  if (a < 0 || b < 0) return false;
  const long first = a < b ? a : b, last = a < b ? b : a;
  /* `a` is the code of the lowest allowed value; the range in codes is between the two, and both
   * must be inside [lo_SI, hi_SI] (mfb_code_within rounded them inwards). */
  const double v_first = ch->offset_SI + ch->scale_SI * (double)first;
  const double v_last = ch->offset_SI + ch->scale_SI * (double)last;
  const double tol = 1e-9 * (fabs(lo_SI) + fabs(hi_SI) + 1);
  if (v_first < lo_SI - tol && v_last < lo_SI - tol) return false;
  if (v_first > hi_SI + tol && v_last > hi_SI + tol) return false;
  *lo = (uint16_t)first;
  *hi = (uint16_t)last;
  return true;
}

static const char* const kMuscleName[2] = {"agonist", "antagonist"};

bool mfb_configure(const mfb_board_si* si, mfb_board_config* out, char* error, size_t size) {
  if (error != NULL && size > 0) error[0] = '\0';
  if (!(si->watchdog_s > 0 && si->watchdog_s <= 10)) {
    if (error) snprintf(error, size, "watchdog_s: expected 0 < s <= 10, found %g", si->watchdog_s);
    return false;
  }
  if (!(si->vent_s >= 0 && si->vent_s <= 60)) {
    if (error) snprintf(error, size, "vent_s: expected 0 <= s <= 60, found %g", si->vent_s);
    return false;
  }
  if (si->joint_count < 1 || si->joint_count > MFB_MAX_JOINTS) {
    if (error) snprintf(error, size, "joint_count: expected 1..%d, found %d", MFB_MAX_JOINTS, si->joint_count);
    return false;
  }
  if (si->estop_line < 0 || si->estop_line > 7) {
    if (error) snprintf(error, size, "estop_line: expected 0..7, found %d", si->estop_line);
    return false;
  }
  if (si->procedure_key_line < -1 || si->procedure_key_line > 7 || si->procedure_key_line == si->estop_line) {
    if (error) snprintf(error, size, "procedure_key_line: expected -1 (none) or 0..7 other than the e-stop's, found %d", si->procedure_key_line);
    return false;
  }
  for (size_t i = 0; i < MFB_KEY_SIZE; ++i) out->key[i] = si->key[i];
  out->watchdog_us = (uint32_t)(si->watchdog_s * 1e6 + 0.5);
  out->vent_us = (uint32_t)(si->vent_s * 1e6 + 0.5);
  out->safe_digital_out = si->safe_digital_out;
  out->estop_line = (uint8_t)si->estop_line;
  out->estop_active_high = si->estop_active_high;
  out->procedure_key_line = (int8_t)si->procedure_key_line;
  out->procedure_key_active_high = si->procedure_key_active_high;
  out->joint_count = (uint8_t)si->joint_count;
  for (int i = 0; i < MFB_DA_CHANNELS; ++i) {
    out->safe_da[i] = si->safe_da[i];
    out->da_min[i] = 0;
    out->da_max[i] = 65535;
    out->da_rise_q16_per_us[i] = 0;
  }
  out->da_rise_up = 0;
  uint8_t da_limited = 0; /* a DA channel limited twice is a channel map error */
  for (int j = 0; j < si->joint_count; ++j) {
    const mfb_joint_si* js = &si->joints[j];
    mfb_joint_limit* jl = &out->joints[j];
    for (int m = 0; m < 2; ++m) {
      const mfb_muscle_si* ms = &js->muscle[m];
      mfb_muscle_limit* ml = &jl->muscle[m];
      if (ms->valve.channel < 0 || !good_channel(&ms->valve, MFB_DA_CHANNELS)) {
        return fail(error, size, j, kMuscleName[m], "valve: expected a DA channel 0..7 with a finite nonzero scale; channel",
                    ms->valve.channel);
      }
      if (!(isfinite(ms->pressure_ceiling_Pa) && ms->pressure_ceiling_Pa > 0)) {
        return fail(error, size, j, kMuscleName[m], "pressure_ceiling_Pa: expected a finite value > 0", ms->pressure_ceiling_Pa);
      }
      const int da = ms->valve.channel;
      if (da_limited & (1u << da)) return fail(error, size, j, kMuscleName[m], "valve: DA channel used twice; channel", da);
      da_limited |= (uint8_t)(1u << da);
      if (!code_range(&ms->valve, 0.0, ms->pressure_ceiling_Pa, &out->da_min[da], &out->da_max[da])) {
        return fail(error, size, j, kMuscleName[m], "pressure_ceiling_Pa: expected a pressure the valve's DA codes reach",
                    ms->pressure_ceiling_Pa);
      }
      if (si->safe_da[da] < out->da_min[da] || si->safe_da[da] > out->da_max[da]) {
        return fail(error, size, j, kMuscleName[m], "valve: expected its safe code inside [0 Pa, ceiling]; safe code",
                    si->safe_da[da]);
      }
      if (!(isfinite(ms->pressure_rise_Pa_per_s) && ms->pressure_rise_Pa_per_s > 0)) {
        return fail(error, size, j, kMuscleName[m], "pressure_rise_Pa_per_s: expected a finite rate > 0", ms->pressure_rise_Pa_per_s);
      }
      /* In 1/65536 codes per microsecond: at least 1 (slower would never move the valve), at most
       * the whole range per microsecond (no limit). */
      const double rise = ms->pressure_rise_Pa_per_s / fabs(ms->valve.scale_SI) * 65536.0 / 1e6;
      if (rise < 1.0) {
        return fail(error, size, j, kMuscleName[m], "pressure_rise_Pa_per_s: expected at least one code per 65.536 ms",
                    ms->pressure_rise_Pa_per_s);
      }
      out->da_rise_q16_per_us[da] = rise > 4294967295.0 ? 4294967295u : (uint32_t)rise;
      if (ms->valve.scale_SI > 0) out->da_rise_up |= (uint8_t)(1u << da);
      if (!(isfinite(ms->force_lead_s) && ms->force_lead_s >= 0 && ms->force_lead_s <= 1.0)) {
        return fail(error, size, j, kMuscleName[m], "force_lead_s: expected 0 <= s <= 1", ms->force_lead_s);
      }
      ml->valve_da = (int8_t)da;
      ml->loadcell_ad = -1;
      ml->trip_above = true;
      ml->trip_code = 65535;
      ml->release_code = 65535;
      ml->lead_us = (uint32_t)(ms->force_lead_s * 1e6 + 0.5);
      if (ms->loadcell.channel >= 0) {
        if (!good_channel(&ms->loadcell, MFB_AD_CHANNELS)) {
          return fail(error, size, j, kMuscleName[m], "loadcell: expected an AD channel 0..15 with a finite nonzero scale; channel",
                      ms->loadcell.channel);
        }
        if (!(isfinite(ms->force_ceiling_N) && ms->force_ceiling_N > 0)) {
          return fail(error, size, j, kMuscleName[m], "force_ceiling_N: expected a finite value > 0", ms->force_ceiling_N);
        }
        const long code = mfb_code_within(&ms->loadcell, ms->force_ceiling_N, +1);
        if (code < 0 || code >= 65535) {
          return fail(error, size, j, kMuscleName[m], "force_ceiling_N: expected a force inside the load cell's range",
                      ms->force_ceiling_N);
        }
        ml->loadcell_ad = (int8_t)ms->loadcell.channel;
        ml->trip_above = ms->loadcell.scale_SI > 0;
        ml->trip_code = (uint16_t)code;
        ml->release_code = (uint16_t)mfb_code_within(&ms->loadcell, MFB_RELEASE_FRACTION * ms->force_ceiling_N, +1);
      }
    }
    jl->motor_da = -1;
    if (js->motor.channel >= 0) {
      if (!good_channel(&js->motor, MFB_DA_CHANNELS)) {
        return fail(error, size, j, "", "motor: expected a DA channel 0..7 with a finite nonzero scale; channel", js->motor.channel);
      }
      const int da = js->motor.channel;
      if (da_limited & (1u << da)) return fail(error, size, j, "", "motor: DA channel used twice; channel", da);
      da_limited |= (uint8_t)(1u << da);
      if (!(isfinite(js->motor_ceiling_Nm) && js->motor_ceiling_Nm > 0) ||
          !code_range(&js->motor, -js->motor_ceiling_Nm, js->motor_ceiling_Nm, &out->da_min[da], &out->da_max[da])) {
        return fail(error, size, j, "", "motor_ceiling_Nm: expected a torque > 0 the motor's DA codes reach", js->motor_ceiling_Nm);
      }
      if (si->safe_da[da] < out->da_min[da] || si->safe_da[da] > out->da_max[da]) {
        return fail(error, size, j, "", "motor: expected its safe code inside the ceiling; safe code", si->safe_da[da]);
      }
      jl->motor_da = (int8_t)da;
    }
    jl->encoder = -1;
    jl->counts_rise_with_angle = true;
    jl->min_counts = INT32_MIN;
    jl->max_counts = INT32_MAX;
    jl->range_vent = false;
    jl->angle_lead_us = 0;
    jl->brake_counts_per_s2 = 0;
    jl->speed_ceiling_counts_per_s = 0;
    jl->speed_lead_us = 0;
    if (!(isfinite(js->speed_ceiling_rad_per_s) && js->speed_ceiling_rad_per_s >= 0)) {
      return fail(error, size, j, "", "speed_ceiling_rad_per_s: expected 0 (none) or a finite speed > 0", js->speed_ceiling_rad_per_s);
    }
    if (js->speed_ceiling_rad_per_s > 0 && js->encoder.channel < 0) {
      return fail(error, size, j, "", "speed_ceiling_rad_per_s: expected 0 for a joint without an encoder", js->speed_ceiling_rad_per_s);
    }
    if (js->encoder.channel >= 0) {
      const mfb_encoder_si* e = &js->encoder;
      if (e->channel >= MFB_ENCODER_CHANNELS || !isfinite(e->rad_per_count) || e->rad_per_count == 0 || !isfinite(e->offset_rad)) {
        return fail(error, size, j, "", "encoder: expected a counter 0..7 with a finite nonzero rad_per_count; channel", e->channel);
      }
      if (!(isfinite(js->min_angle_rad) && isfinite(js->max_angle_rad) && js->min_angle_rad < js->max_angle_rad)) {
        return fail(error, size, j, "", "min_angle_rad < max_angle_rad: expected finite and ordered; min", js->min_angle_rad);
      }
      double a = (js->min_angle_rad - e->offset_rad) / e->rad_per_count;
      double b = (js->max_angle_rad - e->offset_rad) / e->rad_per_count;
      if (a > b) {
        const double t = a;
        a = b;
        b = t;
      }
      if (!(a > -2147483647.0 && b < 2147483647.0)) {
        return fail(error, size, j, "", "angle range: expected it within the counter's int32 range; counts", a);
      }
      if (!(isfinite(js->angle_lead_s) && js->angle_lead_s >= 0 && js->angle_lead_s <= 1.0)) {
        return fail(error, size, j, "", "angle_lead_s: expected 0 <= s <= 1", js->angle_lead_s);
      }
      /* 0: no stopping distance; otherwise at least 1 count/s^2 and small enough that v^2 of any
       * speed the window can measure stays in int64. */
      const double brake = fabs(js->brake_rad_per_s2 / e->rad_per_count);
      if (!(isfinite(js->brake_rad_per_s2) && js->brake_rad_per_s2 >= 0 && (js->brake_rad_per_s2 == 0 || (brake >= 1.0 && brake < 4e9)))) {
        return fail(error, size, j, "", "brake_rad_per_s2: expected 0 (none) or at least one count/s^2", js->brake_rad_per_s2);
      }
      jl->encoder = (int8_t)e->channel;
      jl->counts_rise_with_angle = e->rad_per_count > 0;
      jl->min_counts = (int32_t)ceil(a);
      jl->max_counts = (int32_t)floor(b);
      jl->range_vent = js->range_vent;
      jl->angle_lead_us = js->range_vent ? (uint32_t)(js->angle_lead_s * 1e6 + 0.5) : 0;
      jl->brake_counts_per_s2 = js->range_vent ? (uint32_t)brake : 0;
      /* In counts/s: at least 1, and below the speeds the window measures (clamped at 1e9). */
      const double ceiling = js->speed_ceiling_rad_per_s / fabs(e->rad_per_count);
      if (js->speed_ceiling_rad_per_s > 0 && !(ceiling >= 1.0 && ceiling < 1e9)) {
        return fail(error, size, j, "", "speed_ceiling_rad_per_s: expected at least one count/s and below 1e9 counts/s", js->speed_ceiling_rad_per_s);
      }
      jl->speed_ceiling_counts_per_s = js->speed_ceiling_rad_per_s > 0 ? (uint32_t)ceiling : 0;
      if (!(isfinite(js->speed_lead_s) && js->speed_lead_s >= 0 && js->speed_lead_s <= 1.0)) {
        return fail(error, size, j, "", "speed_lead_s: expected 0 <= s <= 1", js->speed_lead_s);
      }
      jl->speed_lead_us = js->speed_ceiling_rad_per_s > 0 ? (uint32_t)(js->speed_lead_s * 1e6 + 0.5) : 0;
    }
  }
  return true;
}

/* ---- the session (the same rules as peha::mfb::CommandFilter) -------------------------------- */

static mfb_verdict count(mfb_board* b, mfb_verdict v) {
  mfb_counters* c = &b->counters;
  switch (v) {
    case MFB_ACCEPT: ++c->accepted; break;
    case MFB_FOREIGN_SOURCE: ++c->foreign_source; break;
    case MFB_FOREIGN_SESSION: ++c->foreign_session; break;
    case MFB_DUPLICATE: ++c->duplicate; break;
    case MFB_STALE: ++c->stale; break;
    case MFB_MALFORMED: ++c->malformed; break;
    case MFB_UNAUTHENTICATED: ++c->unauthenticated; break;
    case MFB_UNKNOWN_SESSION: ++c->unknown_session; break;
    case MFB_HELLO: ++c->hellos; break;
  }
  return v;
}

static uint32_t nonzero_random(const mfb_hal* hal) {
  uint32_t r = 0;
  while (r == 0) r = hal->random_u32(hal->ctx);
  return r;
}

/* The board nonce for host nonce `session` from `from`: keyed BLAKE2b (the HAL's MAC) under this
 * boot's secret over the epoch, the host nonce and the endpoint - a stateless cookie (as in DTLS
 * and IKEv2), so that answering hellos holds no state a flood could displace. A new boot (new
 * secret) and every session opened (new epoch) make every earlier nonce worthless. */
static uint64_t nonce_for(const mfb_board* b, uint32_t session, mfb_endpoint from) {
  uint8_t in[14];
  const uint32_t words[3] = {b->epoch, session, from.address};
  for (int w = 0; w < 3; ++w) {
    for (int i = 0; i < 4; ++i) in[4 * w + i] = (uint8_t)(words[w] >> (8 * i));
  }
  in[12] = (uint8_t)from.port;
  in[13] = (uint8_t)(from.port >> 8);
  uint8_t mac[MFB_MAC_SIZE];
  b->hal->mac(b->hal->ctx, b->boot_secret, in, sizeof in, mac);
  uint64_t nonce = 0;
  for (int i = 0; i < 8; ++i) nonce |= (uint64_t)mac[i] << (8 * i);
  return nonce != 0 ? nonce : 1; /* 0 means "no session" on the wire */
}

/* ---- arming (the same rules as peha::mfb::OutputArming) -------------------------------------- */

static bool procedure_key_turned(const mfb_board* b) {
  const mfb_board_config* cfg = b->cfg;
  return cfg->procedure_key_line >= 0 &&
         (((b->inputs.digital_in >> cfg->procedure_key_line) & 1u) != 0) == cfg->procedure_key_active_high;
}

static void arming_on_command(mfb_board* b, const mfb_command* c) {
  if (c->board_nonce != b->arm_nonce) { /* a new session makes its own enable edge */
    b->arm_nonce = c->board_nonce;
    b->armed = false;
    b->seen_disable = false;
  }
  if ((c->flags & MFB_COMMAND_ENABLE) == 0) {
    b->armed = false;
    b->seen_disable = !b->estop; /* the edge must start after the e-stop is released */
    b->tripped = false;          /* the host has acknowledged the trip */
  } else if (!b->armed && b->seen_disable && !b->estop &&
             (!b->host_lost || (c->flags & MFB_COMMAND_OPERATOR_ARM) != 0)) {
    b->armed = true;
    b->host_lost = false;
    /* The key counts only when turned before the arming edge: a key turned (or a line that fails
     * active) while a run is armed does not switch its range vent off. */
    b->key_at_arming = procedure_key_turned(b);
  }
}

static void arming_set_estop(mfb_board* b, bool active) {
  b->estop = active;
  if (active) {
    b->armed = false;
    b->seen_disable = false;
  }
}

uint8_t mfb_board_status(const mfb_board* b) {
  uint8_t s = 0;
  if (b->tripped) s |= MFB_STATUS_WATCHDOG_TRIPPED;
  if (!mfb_board_outputs_live(b)) s |= MFB_STATUS_OUTPUTS_SAFE;
  if (b->estop) s |= MFB_STATUS_ESTOP;
  if (b->host_lost) s |= MFB_STATUS_HOST_LOST;
  if (!b->has_session) s |= MFB_STATUS_NO_SESSION;
  return s;
}

/* ---- the board --------------------------------------------------------------------------------- */

static void write_safe(mfb_board* b) {
  for (int i = 0; i < MFB_DA_CHANNELS; ++i) {
    b->applied_da[i] = b->cfg->safe_da[i];
    b->slew_q16[i] = (uint32_t)b->applied_da[i] << 16;
  }
  b->applied_digital = b->cfg->safe_digital_out;
  b->hal->write_outputs(b->hal->ctx, b->applied_da, b->applied_digital);
}

void mfb_board_init(mfb_board* b, const mfb_board_config* cfg, const mfb_hal* hal) {
  *b = (mfb_board){0};
  b->cfg = cfg;
  b->hal = hal;
  b->boot_id = nonzero_random(hal); /* this power-on's id: a restart draws another */
  for (size_t i = 0; i < MFB_KEY_SIZE; i += 4) {
    const uint32_t r = hal->random_u32(hal->ctx);
    for (size_t k = 0; k < 4; ++k) b->boot_secret[i + k] = (uint8_t)(r >> (8 * k));
  }
  b->last_error = MFB_PARSE_OK;
  write_safe(b);
  mfb_board_sample(b);
}

/* Keeps what the answer to `c` from `from` needs. */
static mfb_event answer(mfb_board* b, const mfb_command* c, mfb_endpoint from, uint64_t nonce) {
  b->answer_to = from;
  b->answer_for = *c;
  b->answer_nonce = nonce;
  return MFB_EVENT_ANSWER;
}

mfb_event mfb_board_receive(mfb_board* b, const uint8_t* datagram, size_t size, mfb_endpoint from, mfb_verdict* verdict) {
  mfb_verdict v;
  mfb_command c;
  const mfb_parse_error e = mfb_decode_command(datagram, size, b->cfg->key, b->hal->mac, b->hal->ctx, &c);
  bool opens = false; /* a command that completes a handshake */
  if (e != MFB_PARSE_OK) {
    b->last_error = e;
    v = count(b, e == MFB_PARSE_BAD_MAC ? MFB_UNAUTHENTICATED : MFB_MALFORMED);
  } else if (c.type == MFB_TYPE_HELLO) {
    /* Answered whoever asks: it changes nothing here, and the nonce is good only for this host
     * nonce from this endpoint, until the next session is opened. */
    if (verdict != NULL) *verdict = count(b, MFB_HELLO);
    return answer(b, &c, from, nonce_for(b, c.session_id, from));
  } else if (b->has_session && !(from.address == b->peer.address && from.port == b->peer.port)) {
    v = count(b, MFB_FOREIGN_SOURCE); /* the session belongs to the endpoint that opened it */
  } else if (b->has_session && (c.session_id != b->session_id || c.board_nonce != b->board_nonce)) {
    v = count(b, MFB_FOREIGN_SESSION); /* a second host waits for the watchdog */
  } else {
    const bool released = !b->has_session && b->ever_adopted && c.session_id == b->session_id &&
                          c.board_nonce == b->board_nonce && from.address == b->peer.address && from.port == b->peer.port;
    if (!b->has_session && !released) {
      /* Only a command carrying the nonce this boot answered to its hello opens a session: a
       * recording of any earlier session (another boot, another epoch) never does. */
      if (c.board_nonce != nonce_for(b, c.session_id, from)) {
        if (verdict != NULL) *verdict = count(b, MFB_UNKNOWN_SESSION);
        return answer(b, &c, from, 0);
      }
      opens = true;
      b->have_last = false; /* a new session: its sequence starts a fresh baseline */
    }
    /* Re-adopting the released session keeps its baseline: a late packet cannot revive an old command. */
    if (b->have_last && c.sequence == b->last_sequence) {
      v = count(b, MFB_DUPLICATE);
    } else if (b->have_last && !mfb_sequence_newer(c.sequence, b->last_sequence)) {
      v = count(b, MFB_STALE);
    } else {
      if (b->have_last) b->counters.gaps += (uint32_t)(c.sequence - b->last_sequence - 1u);
      b->have_last = true;
      b->last_sequence = c.sequence;
      v = count(b, MFB_ACCEPT);
    }
  }
  if (verdict != NULL) *verdict = v;
  if (v != MFB_ACCEPT) return MFB_EVENT_DROPPED;

  if (opens) ++b->epoch; /* every nonce answered so far is void: none can open a second session */
  b->has_session = true;
  b->ever_adopted = true;
  b->session_id = c.session_id;
  b->board_nonce = c.board_nonce;
  b->peer = from;
  b->last_command_us = b->hal->now_us(b->hal->ctx);
  arming_on_command(b, &c);
  b->command = c;
  if (!opens) return MFB_EVENT_COMMAND;
  b->live = false;
  b->venting = false;
  write_safe(b);
  return MFB_EVENT_NEW_SESSION;
}

/* The oldest slot of the rate window and its age in ns (0: no rate yet). */
static int64_t window(const mfb_board* b, int* oldest) {
  if (b->history_count < 2) return 0;
  *oldest = b->history_count < MFB_RATE_WINDOW ? 0 : b->history_next;
  const int newest = (b->history_next + MFB_RATE_WINDOW - 1) % MFB_RATE_WINDOW;
  return (int64_t)(b->history_ns[newest] - b->history_ns[*oldest]);
}

/* The load cell's code as a force that grows with it (a falling code is mirrored). */
static int32_t rising(const mfb_muscle_limit* m, uint16_t code) { return m->trip_above ? code : 65535 - (int32_t)code; }

/* The force over its ceiling, or about to be: the code led by its rate over the last
 * MFB_RATE_WINDOW samples times the valve's reaction time, so the vent arrives before the force
 * the valve's dead time and lag would still add. A falling force is judged as it is. */
static bool over_ceiling(const mfb_board* b, int muscle_index, const mfb_muscle_limit* m) {
  if (m->loadcell_ad < 0) return false;
  const int32_t now = rising(m, b->inputs.ad[m->loadcell_ad]);
  int64_t led = now;
  int oldest = 0;
  const int64_t span_ns = m->lead_us > 0 ? window(b, &oldest) : 0;
  if (span_ns > 0) {
    const int64_t delta = now - rising(m, b->history_ad[oldest][muscle_index]);
    if (delta > 0) led += delta * (int64_t)m->lead_us * 1000 / span_ns;
  }
  return led > (int64_t)rising(m, m->trip_code);
}

/* A tripped muscle's force has fallen below half its ceiling: refilled from there, the force trip
 * (led by the rate) stops it again before its ceiling; released nearer the ceiling, its valve's
 * dead time and lag carried the force past it. */
static bool released_below(const mfb_board* b, const mfb_muscle_limit* m) {
  return m->loadcell_ad < 0 || rising(m, b->inputs.ad[m->loadcell_ad]) <= rising(m, m->release_code);
}

/* Joint `j`'s range vents the muscle driving it out: its map asks for it, and the procedure key was
 * not turned before the arming edge (or is not turned now). */
static bool range_vents(const mfb_board* b, int j) {
  return b->cfg->joints[j].range_vent && !(b->armed && b->key_at_arming && procedure_key_turned(b));
}

static int64_t clamp_speed(int64_t speed) { return speed > 1000000000 ? 1000000000 : speed < -1000000000 ? -1000000000 : speed; }

/* Joint `j`'s speed in counts/s over the rate window (0 before there is one), led by `lead_us`
 * times its acceleration (the change of speed from the window's first half to its second, once the
 * window is whole), within +-1e9 so that its square and the lead stay in int64. */
static int64_t joint_speed(const mfb_board* b, int j, uint32_t lead_us) {
  int oldest = 0;
  const int64_t span_ns = window(b, &oldest);
  if (span_ns <= 0) return 0;
  const int64_t counts = b->inputs.encoder[b->cfg->joints[j].encoder];
  const int64_t speed = clamp_speed((counts - b->history_counts[oldest][j]) * 1000000000 / span_ns); /* |delta| < 2^32, span >= 1 ns */
  const int middle = (oldest + (b->history_count - 1) / 2) % MFB_RATE_WINDOW;
  const int64_t first_ns = (int64_t)(b->history_ns[middle] - b->history_ns[oldest]), second_ns = span_ns - first_ns;
  /* The change of speed only over a whole window: over 2 or 3 ms a count's quantisation alone would
   * lead it by hundreds of deg/s. */
  if (lead_us == 0 || b->history_count < MFB_RATE_WINDOW || first_ns <= 0 || second_ns <= 0) return speed;
  const int64_t at_middle = b->history_counts[middle][j];
  const int64_t first = clamp_speed((at_middle - b->history_counts[oldest][j]) * 1000000000 / first_ns);
  const int64_t second = clamp_speed((counts - at_middle) * 1000000000 / second_ns);
  /* the halves' centres are span / 2 apart; |second - first| <= 2e9, x 2e9 ns of lead: in int64 */
  return clamp_speed(speed + (second - first) * 2 * (int64_t)lead_us * 1000 / span_ns);
}

/* Joint `j`'s counts as its range judges them: led, in the direction they move, by the speed over
 * the rate window times the valves' reaction (the muscle keeps pulling that long after its vent)
 * plus the distance the other muscle's deceleration needs to stop the joint. */
static int64_t led_counts(const mfb_board* b, int j) {
  const mfb_joint_limit* jl = &b->cfg->joints[j];
  int64_t led = b->inputs.encoder[jl->encoder];
  if (jl->angle_lead_us > 0 || jl->brake_counts_per_s2 > 0) {
    const int64_t speed = joint_speed(b, j, 0);
    int64_t ahead = speed * (int64_t)jl->angle_lead_us / 1000000;
    if (jl->brake_counts_per_s2 > 0) {
      const int64_t stop = speed * speed / (2 * (int64_t)jl->brake_counts_per_s2);
      ahead += speed > 0 ? stop : -stop;
    }
    led += ahead;
  }
  return led;
}

/* The side joint `j` is (about to be) out of its range on: +1 above max_angle_rad, -1 below
 * min_angle_rad, 0 inside, judged on its led counts. */
static int range_side_inset(const mfb_board* b, int j, int64_t inset_counts) {
  const mfb_joint_limit* jl = &b->cfg->joints[j];
  if (jl->encoder < 0) return 0;
  const int64_t led = led_counts(b, j);
  const int side = led > jl->max_counts - inset_counts ? 1 : led < jl->min_counts + inset_counts ? -1 : 0;
  return jl->counts_rise_with_angle ? side : -side;
}

static int range_side(const mfb_board* b, int j) { return range_side_inset(b, j, 0); }

/* The way joint `j` moves faster than `fraction` of its speed ceiling: +1 up its angle, -1 down, 0
 * slower (or no ceiling). */
static int speed_side(const mfb_board* b, int j, double fraction) {
  const mfb_joint_limit* jl = &b->cfg->joints[j];
  if (jl->speed_ceiling_counts_per_s == 0) return 0;
  const int64_t speed = joint_speed(b, j, jl->speed_lead_us);
  const int64_t ceiling = (int64_t)((double)jl->speed_ceiling_counts_per_s * fraction);
  const int side = speed > ceiling ? 1 : speed < -ceiling ? -1 : 0;
  return jl->counts_rise_with_angle ? side : -side;
}

/* Joint `j` in direction `side` has its braking muscle (the other one) released from a force trip
 * of its own once its load cell is below half its ceiling: a vent of the muscle driving the joint
 * needs the other to stop it. */
static void release_brake(mfb_board* b, int j, int side) {
  const int brake = side > 0 ? MFB_ANTAGONIST : MFB_AGONIST;
  if (released_below(b, &b->cfg->joints[j].muscle[brake])) b->vented_muscles &= (uint16_t)~(1u << (2 * j + brake));
}

int32_t mfb_board_range_margin(const mfb_board* b, int joint) {
  if (joint < 0 || joint >= b->cfg->joint_count || b->cfg->joints[joint].encoder < 0) return INT32_MAX;
  const mfb_joint_limit* jl = &b->cfg->joints[joint];
  const int64_t led = led_counts(b, joint);
  const int64_t above = jl->max_counts - led, below = led - jl->min_counts;
  const int64_t margin = above < below ? above : below;
  return margin > INT32_MAX ? INT32_MAX : margin < INT32_MIN ? INT32_MIN : (int32_t)margin;
}

int32_t mfb_board_speed(const mfb_board* b, int joint) {
  if (joint < 0 || joint >= b->cfg->joint_count || b->cfg->joints[joint].encoder < 0) return 0;
  return (int32_t)joint_speed(b, joint, b->cfg->joints[joint].speed_lead_us); /* within +-1e9 */
}

void mfb_board_sample(mfb_board* b) {
  b->hal->read_inputs(b->hal->ctx, &b->inputs);
  const mfb_board_config* cfg = b->cfg;
  /* The ring of recent load-cell codes and encoder counts (the rates' baseline); a clock that goes
   * back (the emulator's plant restarted with a session) starts it afresh. */
  const int newest = (b->history_next + MFB_RATE_WINDOW - 1) % MFB_RATE_WINDOW;
  if (b->history_count > 0 && b->inputs.time_ns <= b->history_ns[newest]) b->history_count = 0, b->history_next = 0;
  for (int j = 0; j < cfg->joint_count; ++j) {
    const mfb_joint_limit* jl = &cfg->joints[j];
    for (int m = 0; m < 2; ++m) {
      const int8_t ad = jl->muscle[m].loadcell_ad;
      b->history_ad[b->history_next][2 * j + m] = ad >= 0 ? b->inputs.ad[ad] : 0;
    }
    b->history_counts[b->history_next][j] = jl->encoder >= 0 ? b->inputs.encoder[jl->encoder] : 0;
  }
  b->history_ns[b->history_next] = b->inputs.time_ns;
  b->history_next = (uint8_t)((b->history_next + 1) % MFB_RATE_WINDOW);
  if (b->history_count < MFB_RATE_WINDOW) ++b->history_count;
  for (int j = 0; j < cfg->joint_count; ++j) {
    for (int m = 0; m < 2; ++m) {
      const uint16_t bit = (uint16_t)(1u << (2 * j + m));
      if (!(b->vented_muscles & bit) && over_ceiling(b, 2 * j + m, &cfg->joints[j].muscle[m])) {
        b->vented_muscles |= bit;
        ++b->counters.force_trips;
      }
    }
    const uint8_t bit = (uint8_t)(1u << j);
    const int side = range_side(b, j);
    if (side != 0) { /* latched; the muscle vented is the one driving it out now (a swing may cross over) */
      if (!(b->motors_off & bit)) ++b->counters.range_trips;
      /* The range's vent needs the other muscle to brake: a force trip of its own (an earlier
       * swing's) lets it refill as soon as its force is low, without waiting for an arming edge. */
      if (range_vents(b, j)) release_brake(b, j, side);
      b->motors_off |= bit;
      if (side > 0) b->out_high |= bit;
      else b->out_high &= (uint8_t)~bit;
    }
    const int fast = speed_side(b, j, 1.0);
    if (fast != 0) { /* latched per muscle: a swing back vents the other one too, it does not refill the first */
      const uint16_t both = (uint16_t)(3u << (2 * j));
      if (!(b->speed_vented & both)) ++b->counters.speed_trips;
      b->speed_vented |= (uint16_t)(1u << (2 * j + (fast > 0 ? MFB_AGONIST : MFB_ANTAGONIST)));
      if (!(b->speed_vented & (1u << (2 * j + (fast > 0 ? MFB_ANTAGONIST : MFB_AGONIST))))) release_brake(b, j, fast);
    }
  }
}

/* The trips hold until an arming edge finds their cause gone: re-judged from the newest sample. */
static void rejudge_trips(mfb_board* b) {
  const mfb_board_config* cfg = b->cfg;
  const uint16_t tripped = b->vented_muscles;
  const uint8_t was_out = b->motors_off, was_high = b->out_high;
  const uint16_t was_fast = b->speed_vented;
  b->vented_muscles = 0;
  b->motors_off = 0;
  b->out_high = 0;
  b->speed_vented = 0;
  for (int j = 0; j < cfg->joint_count; ++j) {
    for (int m = 0; m < 2; ++m) {
      const uint16_t bit = (uint16_t)(1u << (2 * j + m));
      const mfb_muscle_limit* ml = &cfg->joints[j].muscle[m];
      if ((tripped & bit) ? !released_below(b, ml) : over_ceiling(b, 2 * j + m, ml)) b->vented_muscles |= bit;
    }
    /* A joint's trips are released together: a muscle released while the other still vents
     * refills against nothing and swings the limb. So a force trip that holds keeps the joint's
     * other force trip and its range trip (the muscle it vents, the motor cut) too. */
    const uint16_t both = (uint16_t)(3u << (2 * j));
    const uint8_t bit = (uint8_t)(1u << j);
    const bool force_holds = (b->vented_muscles & both) != 0;
    if (force_holds) b->vented_muscles |= (uint16_t)(tripped & both);
    /* A range trip is released only once the joint's led angle is back inside the range by
     * MFB_RANGE_RELEASE_FRACTION of its span: released at the range's edge, the muscle it vented
     * refilled before its vent had acted, and a host re-arming every 30 ms walked the joint out. */
    const mfb_joint_limit* jl = &cfg->joints[j];
    const int64_t inset = (was_out & bit) ? (int64_t)((double)(jl->max_counts - jl->min_counts) * MFB_RANGE_RELEASE_FRACTION) : 0;
    const int side = range_side_inset(b, j, inset);
    if (side != 0) {
      b->motors_off |= bit;
      if (side > 0) b->out_high |= bit;
    } else if (force_holds && (was_out & bit)) {
      b->motors_off |= bit;
      b->out_high |= (uint8_t)(was_high & bit);
    }
    /* A speed trip is released only once the joint is below MFB_SPEED_RELEASE_FRACTION of its
     * ceiling (and, as the range's, not while a force trip of its joint holds): then its muscles
     * together. */
    const int fast = speed_side(b, j, (was_fast & both) ? MFB_SPEED_RELEASE_FRACTION : 1.0);
    if (fast != 0 || force_holds) b->speed_vented |= (uint16_t)(was_fast & both);
    if (fast != 0) b->speed_vented |= (uint16_t)(1u << (2 * j + (fast > 0 ? MFB_AGONIST : MFB_ANTAGONIST)));
  }
}

/* The muscles a board limit vents now, bit 2 x joint + muscle: those of a force trip and, for a
 * joint (about to be) out of range whose range vents (unless the procedure key was turned before
 * the arming edge and still is), the muscle that drives it further out (the agonist above the
 * range, the antagonist below); the other muscle keeps its command: it brakes and holds. And the
 * muscles a joint's speed ceiling vented (latched). */
static uint16_t limit_vented(const mfb_board* b) {
  const mfb_board_config* cfg = b->cfg;
  uint16_t vented = b->vented_muscles;
  for (int j = 0; j < cfg->joint_count; ++j) {
    if ((b->motors_off & (1u << j)) && range_vents(b, j)) {
      vented |= (uint16_t)(1u << (2 * j + ((b->out_high & (1u << j)) ? MFB_AGONIST : MFB_ANTAGONIST)));
    }
  }
  return vented | b->speed_vented;
}

/* The motors a board limit cuts, bit joint: a joint (about to be) out of range or over its speed
 * ceiling. */
static uint8_t limit_motors_off(const mfb_board* b) {
  uint8_t off = b->motors_off;
  for (int j = 0; j < b->cfg->joint_count; ++j) {
    if (b->speed_vented & (3u << (2 * j))) off |= (uint8_t)(1u << j);
  }
  return off;
}

/* Vented muscles' valves go to their safe codes; a joint (about to be) out of range or over its
 * speed ceiling has its motor at zero torque. */
static void apply_trips(mfb_board* b, uint16_t da[MFB_DA_CHANNELS]) {
  const mfb_board_config* cfg = b->cfg;
  const uint16_t vented = limit_vented(b);
  const uint8_t motors_off = limit_motors_off(b);
  for (int j = 0; j < cfg->joint_count; ++j) {
    const mfb_joint_limit* jl = &cfg->joints[j];
    for (int m = 0; m < 2; ++m) {
      if (vented & (1u << (2 * j + m))) da[jl->muscle[m].valve_da] = cfg->safe_da[jl->muscle[m].valve_da];
    }
    if ((motors_off & (1u << j)) && jl->motor_da >= 0) da[jl->motor_da] = cfg->safe_da[jl->motor_da];
  }
}

/* The slew limit: a code moves towards more pressure at most `da_rise_q16_per_us` per microsecond
 * of sample clock since the last drive, from where the channel was; it falls freely. The fraction
 * of a code is kept, so slow rates are exact. */
static void apply_slew(mfb_board* b, uint16_t da[MFB_DA_CHANNELS], uint64_t elapsed_us) {
  const mfb_board_config* cfg = b->cfg;
  for (int i = 0; i < MFB_DA_CHANNELS; ++i) {
    const uint32_t rise = cfg->da_rise_q16_per_us[i];
    if (rise == 0) continue;
    const bool up = (cfg->da_rise_up >> i) & 1u;
    const uint64_t from = up ? b->slew_q16[i] : (65535u << 16) - b->slew_q16[i]; /* towards more pressure = up */
    const uint64_t wanted = (uint64_t)(up ? da[i] : 65535 - da[i]) << 16;
    const uint64_t limit = from + (uint64_t)rise * elapsed_us;
    if (wanted > limit) {
      const uint32_t held = (uint32_t)limit; /* < wanted <= 65535 << 16 */
      da[i] = (uint16_t)(up ? held >> 16 : 65535 - (held >> 16));
      b->slew_q16[i] = up ? held : (65535u << 16) - held;
      ++b->counters.slewed;
    } else {
      b->slew_q16[i] = (uint32_t)da[i] << 16;
    }
  }
}

void mfb_board_drive(mfb_board* b) {
  const mfb_board_config* cfg = b->cfg;
  const bool estop = ((b->inputs.digital_in >> cfg->estop_line) & 1u) == (cfg->estop_active_high ? 1u : 0u);
  arming_set_estop(b, estop);
  const uint64_t now = b->hal->now_us(b->hal->ctx);
  /* The sample clock since the last drive, capped at the watchdog: a board stalled that long has
   * lost its session anyway. */
  uint64_t elapsed_us = b->inputs.time_ns > b->drive_time_ns ? (b->inputs.time_ns - b->drive_time_ns) / 1000u : 0;
  if (elapsed_us > cfg->watchdog_us) elapsed_us = cfg->watchdog_us;
  b->drive_time_ns = b->inputs.time_ns;
  if (mfb_board_outputs_live(b)) {
    if (!b->live) rejudge_trips(b); /* the arming edge */
    b->live = true;
    b->venting = false;
    for (int i = 0; i < MFB_DA_CHANNELS; ++i) {
      uint16_t code = b->command.da[i];
      if (code < cfg->da_min[i] || code > cfg->da_max[i]) {
        code = code < cfg->da_min[i] ? cfg->da_min[i] : cfg->da_max[i];
        ++b->counters.clamped;
      }
      b->applied_da[i] = code;
    }
    b->applied_digital = b->command.digital_out;
    apply_slew(b, b->applied_da, elapsed_us);
    apply_trips(b, b->applied_da);
  } else {
    if (b->live) { /* the moment of disarming: the ramp starts from what the DA held */
      b->live = false;
      for (int i = 0; i < MFB_DA_CHANNELS; ++i) b->vent_from_da[i] = b->applied_da[i];
      b->vent_from_us = now;
      b->venting = cfg->vent_us > 0;
    }
    if (b->venting) {
      uint64_t elapsed = now - b->vent_from_us;
      if (elapsed >= cfg->vent_us) {
        elapsed = cfg->vent_us;
        b->venting = false;
      }
      const int64_t vent = (int64_t)cfg->vent_us;
      for (int i = 0; i < MFB_DA_CHANNELS; ++i) { /* linear, rounded to the nearest code (half up) */
        const int64_t from = b->vent_from_da[i], delta = (int64_t)cfg->safe_da[i] - from;
        b->applied_da[i] = (uint16_t)((2 * from * vent + 2 * delta * (int64_t)elapsed + vent) / (2 * vent));
      }
      for (int j = 0; j < cfg->joint_count; ++j) { /* every motor straight to its zero-torque code */
        const int8_t m = cfg->joints[j].motor_da;
        if (m >= 0) b->applied_da[m] = cfg->safe_da[m];
      }
      apply_trips(b, b->applied_da);
      b->applied_digital = cfg->safe_digital_out;
    } else {
      for (int i = 0; i < MFB_DA_CHANNELS; ++i) b->applied_da[i] = cfg->safe_da[i];
      b->applied_digital = cfg->safe_digital_out;
    }
  }
  /* The next rise starts from what the channels hold now (a trip's vent, the vent ramp). */
  for (int i = 0; i < MFB_DA_CHANNELS; ++i) {
    if ((b->slew_q16[i] >> 16) != b->applied_da[i]) b->slew_q16[i] = (uint32_t)b->applied_da[i] << 16;
  }
  b->hal->write_outputs(b->hal->ctx, b->applied_da, b->applied_digital);
}

mfb_watchdog mfb_board_poll(mfb_board* b) {
  if (!b->has_session) return MFB_WATCHDOG_QUIET;
  const uint64_t now = b->hal->now_us(b->hal->ctx);
  if (now - b->last_command_us <= b->cfg->watchdog_us) return MFB_WATCHDOG_QUIET;
  const bool was_live = mfb_board_outputs_live(b);
  if (b->armed) b->host_lost = true; /* outputs were live and their host fell silent */
  b->tripped = true;
  b->armed = false;
  b->seen_disable = false;
  b->has_session = false; /* the next valid command of any session is adopted */
  return was_live ? MFB_WATCHDOG_HOST_LOST : MFB_WATCHDOG_TRIPPED;
}

/* One state packet of the latest inputs, for a session (or an asker's), encoded into out. */
static size_t encode_state(mfb_board* b, uint32_t session_id, uint32_t ack_sequence, uint64_t echo_host_time_ns, uint8_t status,
                           uint64_t nonce, uint8_t* out, size_t capacity) {
  mfb_state s;
  s.session_id = session_id;
  s.sequence = ++b->state_sequence;
  s.ack_sequence = ack_sequence;
  s.echo_host_time_ns = echo_host_time_ns;
  s.board_time_ns = b->inputs.time_ns;
  for (int i = 0; i < MFB_AD_CHANNELS; ++i) s.ad[i] = b->inputs.ad[i];
  for (int i = 0; i < MFB_ENCODER_CHANNELS; ++i) s.encoder[i] = b->inputs.encoder[i];
  s.digital_in = b->inputs.digital_in;
  s.status = status;
  s.board_nonce = nonce;
  s.boot_id = b->boot_id;
  s.limit_vented = limit_vented(b);
  s.limit_motor_off = limit_motors_off(b);
  return mfb_encode_state(&s, b->cfg->key, b->hal->mac, b->hal->ctx, out, capacity);
}

size_t mfb_board_state_packet(mfb_board* b, uint8_t* out, size_t capacity) {
  if (!b->ever_adopted || capacity < MFB_STATE_PACKET_SIZE) return 0;
  return encode_state(b, b->session_id, b->command.sequence, b->command.host_time_ns, mfb_board_status(b), b->board_nonce, out, capacity);
}

size_t mfb_board_answer_packet(mfb_board* b, uint8_t* out, size_t capacity, mfb_endpoint* to) {
  if (capacity < MFB_STATE_PACKET_SIZE) return 0;
  *to = b->answer_to;
  /* the asker's session is not held */
  return encode_state(b, b->answer_for.session_id, b->answer_for.sequence, b->answer_for.host_time_ns,
                      (uint8_t)(mfb_board_status(b) | MFB_STATUS_NO_SESSION), b->answer_nonce, out, capacity);
}
