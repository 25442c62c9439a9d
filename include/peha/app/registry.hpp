#pragma once
/// \file
/// The experiments `peha` knows, keyed by a scenario's `experiment:` value: what each runs
/// (`peha run`, with the options it takes), checks (`peha check-config`) and simulates behind the
/// board emulator (`peha mfb-emulator`). The one place the CLI learns what a scenario is.

#include "peha/app/commands.hpp"
#include "peha/config/reader.hpp"
#include "peha/experiments/run_request.hpp"
#include "peha/io/backend.hpp"
#include "peha/mfb/board_emulator.hpp"
#include "peha/mfb/channel_map.hpp"
#include "peha/mfb/link_config.hpp"
#include "peha/runtime/supervisor.hpp"

#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace peha::app {

/// An option of `peha run` that not every experiment takes, and why one refuses it.
struct Refusal {
  std::string option;  ///< e.g. "--agonist-calibration"
  std::string reason;
};

/// What `peha run` does with a scenario: the entry's one experiment, or one of its sub-experiments
/// (chosen by --experiment).
struct RunVariant {
  std::string name;                    ///< --experiment value; empty: the entry has no sub-experiments
  std::string title;                   ///< e.g. "E3 postures"
  /// Of the options not every experiment takes (--case, --agonist-calibration,
  /// --antagonist-calibration, --force-trim-rate, --goniometer-csv, --backend), those it takes; the
  /// real-time options (--rt-priority, --cpu, --telemetry, --recover-after) come with --backend.
  std::vector<std::string> accepts;
  std::vector<Refusal> refusals;       ///< why an option it does not take does not apply (else a generic reason)
  std::vector<Refusal> refused_on_board;  ///< options it takes in-process only, and why
  std::function<int(const config::Document& doc, const experiments::RunRequest& request)> run;
};

/// What `peha check-config` checks the scenario's channel map with: the backend's joints, the `mfb:` section.
struct ScenarioCheck {
  std::vector<std::string> joints;
  std::optional<mfb::LinkConfig> link;
  runtime::SupervisorParams lifecycle;  ///< the scenario's `lifecycle:` (printed with the board's watchdog)
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

struct ExperimentEntry {
  std::string key;          ///< the scenario's `experiment:` value
  std::string kind;         ///< what the scenario describes, e.g. "right-arm" (in messages)
  std::string description;
  std::vector<RunVariant> variants;
  /// Prints the scenario's summary (config::Error on a bad one) and returns what its channel map is checked with.
  std::function<ScenarioCheck(const std::filesystem::path& config, const config::Document& doc)> check;
  /// The board's plant for the emulator's options; nullopt after a message (exit code 2).
  std::function<std::optional<BoardPlant>(const config::Document& doc, const EmulatorOptions& options)> emulator;
};

/// Every experiment, in the order of `peha run --help`.
const std::vector<ExperimentEntry>& experiment_registry();

/// The entry of the scenario's `experiment:` value. Throws config::Error (file:line:column) when
/// the key is missing or names no known experiment, listing the known ones.
const ExperimentEntry& find_experiment(const config::Document& doc);

}  // namespace peha::app
