// `peha mfb-emulator`: the board's side of the MFB protocol in front of the scenario's simulated
// plant (from the registry), until a signal, --max-runtime or --sessions.
#include "peha/app/cli_checks.hpp"
#include "peha/app/commands.hpp"
#include "peha/app/registry.hpp"
#include "peha/io/udp_socket.hpp"
#include "peha/mfb/shared_plant.hpp"
#include "peha/runtime/realtime.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <atomic>
#include <thread>
#include <vector>
#include <csignal>
#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <time.h>
#include <cmath>

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
              options.estop_at_s, options.estop_for_s, options.loss_burst_at_s, options.loss_burst_packets.value_or(0)};
  if (!options.truth_csv.empty()) p.truth_steps = static_cast<std::size_t>(std::ceil(600.0 / period_s));
  return p;
}

/// SIGINT and SIGTERM stop the board(s); the real-time set-up of each board's thread.
runtime::RealtimeOptions stop_on_signals_and_realtime(const EmulatorOptions& options) {
  std::signal(SIGINT, on_stop_signal);
  std::signal(SIGTERM, on_stop_signal);
  runtime::RealtimeOptions rt;
  rt.fifo_priority = options.fifo_priority;
  rt.lock_memory = options.fifo_priority > 0;
  rt.cpu = options.cpu;
  return rt;
}

int serve(mfb::BoardEmulator& board, const mfb::EmulatorParams& p, const EmulatorOptions& options, const std::string& what) {
  const runtime::RealtimeOptions rt = stop_on_signals_and_realtime(options);
  const runtime::RealtimeReport report = runtime::configure_realtime_thread(rt);
  (void)report;  // its warnings were printed; the board runs best-effort without
  fmt::print("peha mfb-emulator: listening on udp://{} - {}, watchdog {} ms, vent {} s{}\n", board.local().to_string(), what,
             p.watchdog_s * 1e3, p.vent_s,
             p.faults.any() ? fmt::format("; injecting loss {} duplicate {} reorder {} corrupt {} delay {} ms{}{}", p.faults.loss,
                                          p.faults.duplicate, p.faults.reorder, p.faults.corrupt, options.delay_ms,
                                          p.faults.estop_from_s >= 0
                                              ? fmt::format(", e-stop at {} s for {} s", p.faults.estop_from_s, p.faults.estop_for_s)
                                              : std::string(),
                                          p.faults.burst_from_s >= 0
                                              ? fmt::format(", loss burst at {} s of {}", p.faults.burst_from_s,
                                                            p.faults.burst_packets == 0 ? std::string("every packet to the end")
                                                                                        : fmt::format("{} packets", p.faults.burst_packets))
                                              : std::string())
                            : std::string());
  std::fflush(stdout);
  board.run(g_stop);
  if (board.stats().host_loss_ns != 0) {
    fmt::print("peha mfb-emulator: host lost: the watchdog fired at t={:.4f} s (monotonic {} ns) while the outputs were armed\n",
               board.stats().host_loss_t_s, board.stats().host_loss_ns);
  }
  if (!options.truth_csv.empty()) {
    // A one-joint map's columns are unprefixed; several joints' carry the map's joint name, as `R_EFE_angle_rad`.
    const std::vector<std::string>& names = board.channel_map().joint_names();
    const int joints = static_cast<int>(names.size());
    std::ofstream csv(options.truth_csv);
    csv << "t_s,mono_ns";
    for (int j = 0; j < joints; ++j) {
      const std::string p = joints == 1 ? std::string() : names[static_cast<std::size_t>(j)] + "_";
      csv << fmt::format(",{0}angle_rad,{0}agonist_loadcell_N,{0}antagonist_loadcell_N", p);
    }
    csv << ",armed,motor_off\n";
    const std::vector<mfb::BoardEmulator::TruthRow>& rows = board.truth();
    for (std::size_t i = 0; i < rows.size(); ++i) {
      csv << fmt::format("{:.6f},{}", rows[i].t_s, rows[i].mono_ns);
      for (int j = 0; j < joints; ++j) {
        const mfb::BoardEmulator::TruthJoint& t = board.truth_joint(i, j);
        csv << fmt::format(",{:.7f},{:.4f},{:.4f}", t.angle_rad, t.agonist_N, t.antagonist_N);
      }
      csv << fmt::format(",{},{}\n", rows[i].armed ? 1 : 0, rows[i].motor_off ? 1 : 0);
    }
    if (!csv) throw std::runtime_error(fmt::format("mfb-emulator: cannot write {}", options.truth_csv.string()));
  }
  fmt::print("peha mfb-emulator: stopped\n{}\n", board.stats().table());
  return 0;
}

/// A scenario on several boards: one BoardEmulator per board (its socket at --port + i, its channel
/// map, its key, its watchdog), each in its own thread, all in front of one simulated body
/// (mfb::SharedPlant). Stops them all together.
int serve_boards(BoardPlant& plant, const EmulatorOptions& options) {
  const std::size_t n = plant.link.boards.size();
  const std::vector<std::string> io_joints = plant.make_plant()->info().joint_names;
  mfb::EmulatorParams base = emulator_params(options, plant.period_s, plant.link);
  // A cycle waits this long for a live board's command before the body steps without it (a lost
  // command; the host's next cycle closes it sooner).
  const double wait_s = 3.0 * plant.period_s;  // and a board without a command for 4 waits is not waited for
  const auto body = mfb::SharedPlant::create(plant.make_plant, static_cast<int>(n), plant.period_s, wait_s);
  std::vector<std::unique_ptr<mfb::BoardEmulator>> boards;
  std::string where;
  for (std::size_t b = 0; b < n; ++b) {
    const mfb::BoardLink& link = plant.link.boards[b];
    std::vector<int> io_index;
    for (const std::string& joint : link.joint_names) {
      io_index.push_back(static_cast<int>(std::find(io_joints.begin(), io_joints.end(), joint) - io_joints.begin()));
    }
    mfb::EmulatorParams p = base;
    if (p.bind.port != 0) p.bind.port = static_cast<std::uint16_t>(options.port + static_cast<int>(b));
    p.key = mfb::load_link_key(link.key_file);
    p.faults.seed = options.fault_seed + b;  // each board's own draws
    boards.push_back(std::make_unique<mfb::BoardEmulator>(p, plant.maps[b], [body, b, io_index] { return body->view(static_cast<int>(b), io_index); }));
    boards.back()->set_step_hook([body, b](const mfb::CommandPacket* c) { body->note_command(static_cast<int>(b), c); });
    where += fmt::format("{}udp://{} (board '{}': {})", b ? ", " : "", boards.back()->local().to_string(), link.name, fmt::join(link.joint_names, " "));
  }
  const runtime::RealtimeOptions rt = stop_on_signals_and_realtime(options);
  fmt::print("peha mfb-emulator: listening on {} - {}, one body stepped once per host cycle with every board's command (waiting at most {} ms "
             "for a late one), watchdog {} ms, vent {} s\n",
             where, plant.what, wait_s * 1e3, base.watchdog_s * 1e3, base.vent_s);
  std::fflush(stdout);
  // Each board ends on the signal, its own --max-runtime/--sessions, or when another board ended.
  std::atomic<bool> stop{false};
  std::atomic<int> ended{0};
  std::vector<std::thread> threads;
  for (std::size_t b = 0; b < n; ++b) {
    threads.emplace_back([&, b] {
      (void)runtime::configure_realtime_thread(rt);  // its warnings were printed; the board runs best-effort without
      boards[b]->run(stop);
      ++ended;
    });
  }
  while (!g_stop && ended == 0) {
    const timespec pause{0, 5'000'000};
    nanosleep(&pause, nullptr);
  }
  stop = true;
  for (std::thread& t : threads) t.join();
  fmt::print("peha mfb-emulator: stopped; the body took {} steps ({} host cycles without every board's command)\n", body->steps(), body->partial_steps());
  for (std::size_t b = 0; b < n; ++b) fmt::print("board '{}':\n{}\n", plant.link.boards[b].name, boards[b]->stats().table());
  return 0;
}

}  // namespace

int mfb_emulator(const EmulatorOptions& options) {
  return with_exit_codes([&] {
    const config::Document doc = config::Document::load_file(options.config);
    if (!options.truth_csv.empty()) refuse_unsafe_output(options.truth_csv, scenario_inputs(options.config), "--truth-csv");
    std::optional<BoardPlant> plant = find_experiment(doc).emulator(doc, {options.case_name, options.seed});
    if (!plant) return 2;
    if (plant->link.boards.size() > 1) {
      if (!options.truth_csv.empty()) throw std::runtime_error("mfb-emulator: --truth-csv records one board's plant; this scenario has several boards");
      return serve_boards(*plant, options);
    }
    mfb::EmulatorParams p = emulator_params(options, plant->period_s, plant->link);
    if (options.bind_retry_s > 0 && p.bind.port != 0) {
      // A rebooting board's successor: started while the old one still holds the port, it takes the
      // port the moment it is free (a real board is back within milliseconds of its reset). Its plant
      // is built before the wait, so that taking over costs a bind, not a MuJoCo model's compilation
      // (under load that took longer than the host's 20 ms watchdog: `backend silent` instead of
      // `board reboot` in the link matrix's reboot row).
      auto prebuilt = std::make_shared<std::unique_ptr<io::Backend>>(plant->make_plant());
      plant->make_plant = [prebuilt, fresh = plant->make_plant]() -> std::unique_ptr<io::Backend> {
        if (*prebuilt) return std::move(*prebuilt);
        return fresh();
      };
      const std::int64_t give_up = io::monotonic_ns() + static_cast<std::int64_t>(options.bind_retry_s * 1e9);
      bool told = false;
      for (;;) {
        try {
          io::UdpSocket probe(p.bind);
          break;
        } catch (const std::exception&) {
          if (io::monotonic_ns() > give_up) throw;
          if (!told) {
            fmt::print("peha mfb-emulator: waiting for udp://{} to be free\n", p.bind.to_string());
            std::fflush(stdout);
            told = true;
          }
          const timespec pause{0, 200'000};
          nanosleep(&pause, nullptr);
        }
      }
    }
    mfb::BoardEmulator board(p, std::move(plant->maps.front()), plant->make_plant);
    if (plant->input_hook) board.set_input_hook(plant->input_hook);
    return serve(board, p, options, plant->what);
  });
}

}  // namespace peha::app
