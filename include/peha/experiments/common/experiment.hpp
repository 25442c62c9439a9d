#pragma once
/// \file
/// The experiment contract: what one experiment declares (the options it takes, the hardware it
/// runs on) and provides (a scenario check, the emulator's plant, a run), and the one run sequence
/// that serves every experiment (`run_sequence`): the seed, --case, the hardware check, the run
/// directory, the progress, the verdict line, the plot and the exit code are decided there once.
///
/// A new experiment is one folder under experiments/ with a `*_contract.cpp` returning its
/// `Experiment`, and one row in app/registry.cpp. `peha run` derives its refusals of options from
/// `Takes`; `peha check-config` calls `check`; `peha mfb-emulator` calls `emulator`.

#include "peha/config/reader.hpp"
#include "peha/experiments/run_request.hpp"
#include "peha/io/backend.hpp"
#include "peha/mfb/board_core.hpp"
#include "peha/mfb/board_emulator.hpp"
#include "peha/mfb/channel_map.hpp"
#include "peha/mfb/link_config.hpp"
#include "peha/models/joint.hpp"
#include "peha/runtime/csv_log.hpp"
#include "peha/runtime/log_telemetry.hpp"
#include "peha/runtime/supervisor.hpp"
#include "peha/safety/limits.hpp"
#include "peha/sim/plant_faults.hpp"

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace peha::experiments {

/// The options of `peha run` an experiment takes beyond the ones every experiment takes (--seed,
/// --out, --name, --no-plot, --video), and the hardware it runs on. The CLI refuses every other one,
/// naming the experiments that do take it (app/run_command.cpp).
struct Takes {
  bool cases = false;                   ///< --case (its cases: ExperimentRun::case_names)
  bool calibration = false;             ///< --agonist-calibration / --antagonist-calibration
  bool force_trim = false;              ///< --force-trim-rate
  bool goniometer_csv = false;          ///< --goniometer-csv (a recorded person, in process)
  bool gravity_identification = false;  ///< --gravity-identification
  bool faults = false;                  ///< --fault (injected into the simulated plant, in process)
  bool boards = false;                  ///< --backend udp://... (real time on the board(s))
  bool replay = false;                  ///< --backend replay:<log.csv>
  /// Why it runs in process only or cannot replay (shown when --backend asks for what it cannot).
  std::string why_not_hardware;
};

/// A request the experiment cannot run (a malformed --fault, no section for it in the scenario):
/// `peha run` prints it and exits 2, before anything is written.
struct RequestError : std::invalid_argument {
  using std::invalid_argument::invalid_argument;
};

/// Where a case runs: the run directory and the hardware the door opens for it.
struct RunContext {
  std::filesystem::path dir;
  const RunRequest& request;
  hardware::BackendUri backend;                ///< sim:, replay: (in process) or udp:// (real time)
  std::optional<HardwareRunOptions> realtime;  ///< set on boards only (dir filled in, and the telemetry)
  runtime::TelemetryOptions telemetry;         ///< the run's (telemetry_options): in process a TelemetryTee streams with it
  /// The folder to name to the user: where the run will be once in place (`dir` is its partial folder).
  std::filesystem::path shown_dir() const { return request.run_folder.empty() ? dir : request.run_folder; }
};

/// What an experiment's live telemetry can stream: its per-cycle log's columns (empty: it has none)
/// and the scenario's `telemetry:` section (runtime::read_telemetry).
struct TelemetrySource {
  std::vector<std::string> columns;
  runtime::TelemetryOptions scenario;
};

/// What an experiment concluded: the figures it judged that failed, and what it wrote.
struct Conclusion {
  std::size_t failed_figures = 0;  ///< 0: every figure of the verdict held
  std::string written;             ///< the files it wrote, for the "written:" line
  std::string plot_tool;           ///< tools/<plot_tool> renders the figures (empty: none)
  std::vector<std::string> plot_args;
  /// Figures that failed in runs shown for comparison only (the paper's parametric model alone, its
  /// open-loop replay): reported, labelled with `comparison`, not judged.
  std::size_t comparison_failures = 0;
  std::string comparison;
};

/// One experiment's part of a run: built from the scenario and the request (throws config::Error or
/// RequestError on bad input, before anything is written), then driven by run_sequence.
class ExperimentRun {
 public:
  virtual ~ExperimentRun() = default;
  virtual std::uint64_t seed() const = 0;                  ///< after --seed
  virtual const mfb::LinkConfig* link() const = 0;         ///< the scenario's mfb: section, nullptr without one
  /// The cases --case chooses among, in the scenario's order; empty: the experiment is one run.
  virtual std::vector<std::string> case_names() const = 0;
  /// What runs, printed once the run directory exists (`cases`: the selected ones).
  virtual void print_header(const RunContext& ctx, const std::vector<std::size_t>& cases) const = 0;
  /// Runs case `i` (an index into case_names(); 0 for a one-run experiment) on ctx's hardware.
  virtual void run_case(std::size_t i, const RunContext& ctx) = 0;
  /// Writes the summary files, prints the table and the verdict.
  virtual Conclusion conclude(const RunContext& ctx) = 0;
  /// What --telemetry can stream (checked before anything is written); default: no per-cycle log.
  virtual TelemetrySource telemetry_source() const { return {}; }
};

/// The one run sequence: selects the cases (--case, listing them when none matches), checks the
/// hardware (--backend: one case on a board or a replay, the mfb: section, the addresses), opens the
/// run directory, prints the header, runs each case with its progress, concludes, plots, prints
/// `PASSED` or `FAILED (n figures)`. Returns 0 (passed), 2 (bad request: nothing written) or 3.
int run_sequence(const config::Document& doc, const RunRequest& request, ExperimentRun& experiment);

/// What `peha check-config` checks the scenario's channel map with: the backend's joints, the `mfb:` section.
struct ScenarioCheck {
  std::vector<std::string> joints;
  std::optional<mfb::LinkConfig> link;
  runtime::SupervisorParams lifecycle;  ///< the scenario's `lifecycle:` (printed with the board's watchdog)
  /// Per io joint, the scenario's own hard numbers: the boards' `board_limits:` must agree with them.
  std::vector<mfb::JointEnvelope> envelopes;
};

/// One joint's envelope from the controller's set-up of it and the limits' range and rates.
mfb::JointEnvelope joint_envelope(const std::string& name, const models::JointModel& joint, const safety::JointLimits& limits);

/// What `peha mfb-emulator` was asked to simulate.
struct EmulatorCase {
  std::string case_name;              ///< --case (empty: the only one)
  std::optional<std::uint64_t> seed;  ///< --seed (sensor noise)
};

/// The simulated plant behind `peha mfb-emulator`, with what the board needs to serve it.
struct BoardPlant {
  double period_s = 1e-3;
  mfb::LinkConfig link;
  /// One channel map per board of `link.boards` (one for a single-board scenario).
  std::vector<mfb::ChannelMap> maps;
  /// The whole body (every io joint), in its initial state; several boards share it (mfb::SharedPlant).
  std::function<std::unique_ptr<io::Backend>()> make_plant;
  std::function<void(double t_s, mfb::BoardInputs& inputs)> input_hook;  ///< empty: none
  std::string what;                                                       ///< printed when it listens
};

/// One of an experiment's runs (`--experiment NAME` among several of one scenario kind).
struct RunVariant {
  std::string name;   ///< --experiment value; empty: the scenario kind has one experiment
  std::string title;  ///< e.g. "E3 postures"
  Takes takes;
  std::function<std::unique_ptr<ExperimentRun>(const config::Document& doc, const RunRequest& request)> make_run;
};

/// An experiment as the CLI knows it, keyed by a scenario's `experiment:` value.
struct Experiment {
  std::string key;          ///< the scenario's `experiment:` value
  std::string kind;         ///< what the scenario describes, e.g. "arm" (in messages)
  std::string description;
  std::vector<RunVariant> variants;
  /// Prints the scenario's summary (config::Error on a bad one) and returns what its channel map is checked with.
  std::function<ScenarioCheck(const std::filesystem::path& config, const config::Document& doc)> check;
  /// The board's plant for the emulator's case; nullopt after a message (exit code 2).
  std::function<std::optional<BoardPlant>(const config::Document& doc, const EmulatorCase& request)> emulator;
};

/// The emulator's plant of one case: the one the door simulates for `request` (exactly what a sim:
/// run of the same case drives), behind the scenario's one board.
BoardPlant board_for(const mfb::LinkConfig& link, double period_s, const hardware::HardwareRequest& request, std::string what);
/// `peha mfb-emulator` plays no outage of the in-process plant (state_loss, board_reboot: its gate
/// withholds the samples or switches the board off; over UDP the link's faults play them, `peha
/// faults --link`): empty when `faults` has none, else the error naming the first.
std::string emulator_outage_error(const std::vector<sim::PlantFault>& faults);

/// The index of the emulator's --case among `names` (the only one when none is given); nullopt after
/// a message listing the cases (`meaning`: what a case is; `also`: cases served besides `names`).
std::optional<std::size_t> emulator_case(const config::Document& doc, const std::vector<std::string>& names, const std::string& given,
                                         const char* meaning, const std::string& also);

/// The scenario's mfb: section exists; false after a message.
bool has_link(const config::Document& doc, const std::optional<mfb::LinkConfig>& link);

/// The end of a case's stream in process: sends what is queued and prints what streamed (nothing
/// when `tee` was not streaming).
void finish_telemetry(runtime::TelemetryTee& tee);

/// The end of a case run in process through the door: writes its per-cycle log `<prefix>_<case>.csv`
/// with `comments`, prints how long it ran and how fast, ends its stream (`tee`, finish_telemetry),
/// and for a replay writes the commands beside the recorded ones (replay_<case>.csv).
void finish_in_process_case(const RunContext& ctx, const hardware::Hardware& hw, const runtime::CsvLog& log, runtime::TelemetryTee& tee,
                            const char* prefix,
                            const std::string& case_name, const std::vector<std::string>& comments, double simulated_s,
                            double realtime_factor);

/// The failed checks of a verdict (for Conclusion::failed_figures).
std::size_t failed_figures(const safety::Verdict& verdict);

}  // namespace peha::experiments
