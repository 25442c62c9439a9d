// `peha mfb-emulator`: the board's side of the MFB protocol in front of the scenario's simulated
// plant (from the registry), until a signal, --max-runtime or --sessions.
#include "peha/app/commands.hpp"
#include "peha/app/registry.hpp"
#include "peha/io/udp_socket.hpp"
#include "peha/runtime/realtime.hpp"

#include <fmt/format.h>

#include <atomic>
#include <csignal>
#include <cstdio>

namespace peha::app {
namespace {

std::atomic<bool> g_stop{false};
extern "C" void on_stop_signal(int) { g_stop = true; }

mfb::EmulatorParams emulator_params(const EmulatorOptions& options, double period_s, const mfb::LinkConfig& link) {
  mfb::EmulatorParams p;
  p.bind = {io::parse_ipv4(options.bind), static_cast<std::uint16_t>(options.port)};
  p.period_s = period_s;
  p.watchdog_s = options.watchdog_ms ? *options.watchdog_ms * 1e-3 : link.board_watchdog_s;
  p.vent_s = link.vent_s;
  p.key = mfb::load_link_key(link.key_file);
  p.max_runtime_s = options.max_runtime_s;
  p.sessions = options.sessions;
  p.faults = {options.loss, options.duplicate, options.reorder, options.corrupt, options.delay_ms * 1e-3, options.fault_seed,
              options.estop_at_s, options.estop_for_s};
  return p;
}

int serve(mfb::BoardEmulator& board, const mfb::EmulatorParams& p, const EmulatorOptions& options, const std::string& what) {
  std::signal(SIGINT, on_stop_signal);
  std::signal(SIGTERM, on_stop_signal);
  runtime::RealtimeOptions rt;
  rt.fifo_priority = options.fifo_priority;
  rt.lock_memory = options.fifo_priority > 0;
  rt.cpu = options.cpu;
  const runtime::RealtimeReport report = runtime::configure_realtime_thread(rt);
  (void)report;  // its warnings were printed; the board runs best-effort without
  fmt::print("peha mfb-emulator: listening on udp://{} - {}, watchdog {} ms, vent {} s{}\n", board.local().to_string(), what,
             p.watchdog_s * 1e3, p.vent_s,
             p.faults.any() ? fmt::format("; injecting loss {} duplicate {} reorder {} corrupt {} delay {} ms{}", p.faults.loss,
                                          p.faults.duplicate, p.faults.reorder, p.faults.corrupt, options.delay_ms,
                                          p.faults.estop_from_s >= 0
                                              ? fmt::format(", e-stop at {} s for {} s", p.faults.estop_from_s, p.faults.estop_for_s)
                                              : std::string())
                            : std::string());
  std::fflush(stdout);
  board.run(g_stop);
  fmt::print("peha mfb-emulator: stopped\n{}\n", board.stats().table());
  return 0;
}

}  // namespace

int mfb_emulator(const EmulatorOptions& options) {
  return with_exit_codes([&] {
    const config::Document doc = config::Document::load_file(options.config);
    std::optional<BoardPlant> plant = find_experiment(doc).emulator(doc, options);
    if (!plant) return 2;
    const mfb::EmulatorParams p = emulator_params(options, plant->period_s, plant->link);
    mfb::BoardEmulator board(p, std::move(plant->map), plant->make_plant);
    if (plant->input_hook) board.set_input_hook(plant->input_hook);
    return serve(board, p, options, plant->what);
  });
}

}  // namespace peha::app
