#include "peha/experiments/false_alarms/false_alarms.hpp"

#include "peha/experiments/common/job_pool.hpp"

#include "peha/experiments/common/mujoco_lock.hpp"
#include "peha/experiments/common/scenario_header.hpp"
#include "peha/experiments/e3_postures/postures.hpp"
#include "peha/experiments/e4_goniometer/goniometer.hpp"
#include "peha/hardware/door.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <fstream>
#include <memory>
#include <mutex>
#include <numbers>
#include <thread>

namespace peha::experiments {
namespace {

const char* run_key(FalseAlarmRun r) {
  switch (r) {
    case FalseAlarmRun::kE1: return "e1";
    case FalseAlarmRun::kPostures: return "postures";
    case FalseAlarmRun::kGoniometer: return "goniometer";
  }
  return "?";
}

/// One job: a case's scenario under one plant variant, noise scale and seed (E1: every payload, E4:
/// every movement - several rows).
struct AlarmRun {
  const FalseAlarmCase* what;
  PlantVariant variant;  ///< sensor_noise_scale already multiplied by the noise scale
  std::string variant_name;
  double noise_scale;
  std::uint64_t seed;
};

/// A run's row from its result (E1Result, PosturesResult, GoniometerResult).
template <class Result>
FalseAlarmRow row_of(const AlarmRun& job, std::string case_name, double duration_s, const Result& r) {
  return {std::move(case_name), job.variant_name, job.noise_scale, job.seed, duration_s, r.fault_flags, r.first_fault_flag, r.check_peaks};
}

std::vector<FalseAlarmRow> run_e1(const FalseAlarmConfig& config, const AlarmRun& job) {
  E1Scenario scenario = read_e1(config::Document::load_file(job.what->scenario));
  if (config.e1_duration_s > 0) scenario.duration_s = config.e1_duration_s;
  if (config.adjust_thresholds) config.adjust_thresholds(scenario.limits.monitor);
  std::vector<FalseAlarmRow> rows;
  for (const E1Case& c : scenario.cases) {
    sim::OneDofRigParams plant_params = e1_variant_plant(scenario, c, job.variant);
    plant_params.seed = job.seed;
    std::unique_ptr<sim::OneDofRigBackend> plant;
    {
      const std::lock_guard lock(mujoco_load_mutex());
      plant = std::make_unique<sim::OneDofRigBackend>(plant_params);
    }
    const E1Result r = run_e1_on(scenario, c, *plant, plant.get(), nullptr);
    rows.push_back(row_of(job, job.what->name + "_" + c.name, scenario.duration_s, r));
  }
  return rows;
}

ArmScenario arm_scenario(const FalseAlarmConfig& config, const AlarmRun& job) {
  const ArmScenario nominal = read_arm_scenario(config::Document::load_file(job.what->scenario));
  ArmScenario scenario = nominal;
  if (config.adjust_thresholds) config.adjust_thresholds(scenario.limits.monitor);
  scenario.plant = arm_variant_plant(nominal, job.variant);
  scenario.plant.seed = scenario.seed = job.seed;
  return scenario;
}

std::vector<FalseAlarmRow> run_postures_job(const FalseAlarmConfig& config, const AlarmRun& job) {
  const ArmScenario scenario = arm_scenario(config, job);
  std::unique_ptr<sim::ArmBackend> plant;
  {
    const std::lock_guard lock(mujoco_load_mutex());
    plant = std::make_unique<sim::ArmBackend>(postures_plant_params(scenario));
  }
  const PosturesResult r = run_postures_on(scenario, *plant, plant.get(), nullptr);
  return {row_of(job, job.what->name, postures_duration_s(scenario), r)};
}

std::vector<FalseAlarmRow> run_goniometer_job(const FalseAlarmConfig& config, const AlarmRun& job) {
  const ArmScenario scenario = arm_scenario(config, job);
  const auto& g = scenario.goniometer;
  std::vector<FalseAlarmRow> rows;
  for (std::size_t i = 0; i < g.movements.size(); ++i) {
    const std::vector<GoniometerTrace> traces = synthesize_goniometers(g, g.movements[i], job.seed + i);
    // The door's simulated arm takes MuJoCo's loading lock itself (arm_hardware): taking it here too
    // deadlocked the first E4 job.
    const hardware::Hardware hw =
        hardware::open_backend(hardware::BackendUri{}, goniometer_hardware(scenario, goniometer_plant_params(scenario, traces)));
    const GoniometerResult r = run_goniometer(scenario, traces, GoniometerVariant::kOpenLoop, hw, nullptr);
    rows.push_back(row_of(job, job.what->name + "_" + traces.front().name, goniometer_run_duration_s(scenario, traces.front()), r));
  }
  return rows;
}

std::vector<AlarmRun> false_alarm_jobs(const FalseAlarmConfig& config) {
  std::vector<AlarmRun> jobs;
  for (const FalseAlarmCase& c : config.cases) {
    for (double k : config.noise_scales) {
      PlantVariant v;
      v.name = "nominal";
      v.sensor_noise_scale = k;
      for (int s = 1; s <= config.seeds; ++s) jobs.push_back({&c, v, "nominal", k, static_cast<std::uint64_t>(s)});
    }
    for (const PlantVariant& v : config.variants) {
      if (std::find(c.skip_variants.begin(), c.skip_variants.end(), v.name) != c.skip_variants.end()) continue;
      for (int s = 1; s <= config.variant_seeds; ++s) jobs.push_back({&c, v, v.name, 1.0, static_cast<std::uint64_t>(s)});
    }
  }
  return jobs;
}

/// The p-quantile of `x` (linear between order statistics).
double quantile(std::vector<double> x, double p) {
  if (x.empty()) return 0.0;
  std::sort(x.begin(), x.end());
  const double pos = p * static_cast<double>(x.size() - 1);
  const auto i = static_cast<std::size_t>(pos);
  const double f = pos - static_cast<double>(i);
  return i + 1 < x.size() ? x[i] * (1 - f) + x[i + 1] * f : x[i];
}

/// False alarms per hour from runs' peak ratios `x` of `run_s` seconds each: a Gumbel law fitted by
/// its moments, P(peak >= 1) per run.
double gumbel_rate_per_h(const std::vector<double>& x, double run_s) {
  if (x.size() < 2 || run_s <= 0) return 0.0;
  double mean = 0, var = 0;
  for (double v : x) mean += v;
  mean /= static_cast<double>(x.size());
  for (double v : x) var += (v - mean) * (v - mean);
  var /= static_cast<double>(x.size() - 1);
  const double beta = std::sqrt(6.0 * var) / std::numbers::pi;
  if (beta <= 0) return mean >= 1 ? 3600.0 / run_s : 0.0;
  const double mu = mean - std::numbers::egamma * beta;
  const double p_run = -std::expm1(-std::exp(-(1.0 - mu) / beta));
  return p_run * 3600.0 / run_s;
}

std::string worst_of(const FalseAlarmRow& r) {
  return fmt::format("{} {} x{:g} seed {}", r.case_name, r.variant, r.noise_scale, r.seed);
}

}  // namespace

FalseAlarmConfig read_false_alarms(const config::Document& doc) {
  config::Map root = doc.root();
  read_scenario_header(root, "false_alarms");
  FalseAlarmConfig c;
  const std::vector<std::string> runs = {"e1", "postures", "goniometer"};
  for (config::Map m : root.maps("cases", 1, 32)) {
    FalseAlarmCase fc;
    fc.name = m.string("name");
    const std::string run = m.choice("run", runs);
    fc.run = run == "e1" ? FalseAlarmRun::kE1 : run == "postures" ? FalseAlarmRun::kPostures : FalseAlarmRun::kGoniometer;
    fc.scenario = m.path_value("scenario");
    if (m.has("skip_variants")) {
      for (config::Map sv : m.maps("skip_variants", 1, 64)) {
        fc.skip_variants.push_back(sv.string("name"));
        sv.string("why");
        sv.finish();
      }
    }
    m.finish();
    c.cases.push_back(fc);
  }
  c.noise_scales = root.numbers("noise_scales", {0.0, 100.0}, 1, 8);
  if (c.noise_scales.front() != 1.0) root.fail("noise_scales", "the first noise scale must be 1 (the shipped sensors): the margin is judged there");
  c.seeds = static_cast<int>(root.integer("seeds", 1, 1000));
  c.variant_seeds = static_cast<int>(root.integer("variant_seeds", 0, 1000));
  c.margin_goal = root.number_or("margin_goal", c.margin_goal, {1.0, 10.0});
  c.threads = static_cast<int>(root.integer("threads", 1, 64));
  c.e1_duration_s = root.number_or("e1_duration_s", 0.0, {0.0, 3600.0});
  if (root.has("variants_from")) {
    // The robustness matrix's variants, but its nominal (the noise scales run it) and those the
    // file names as faults the monitor must raise (a load-cell zero off at power-on).
    const RobustnessConfig robustness = read_robustness(config::Document::load_file(root.path_value("variants_from")));
    std::vector<std::string> skip;
    if (root.has("skip_variants")) {
      for (config::Map s : root.maps("skip_variants", 1, 64)) {
        skip.push_back(s.string("name"));
        s.string("why");
        s.finish();
      }
    }
    for (const PlantVariant& v : robustness.variants) {
      if (v.name != "nominal" && std::find(skip.begin(), skip.end(), v.name) == skip.end()) c.variants.push_back(v);
    }
  }
  for (const FalseAlarmCase& fc : c.cases) {  // a case's skip names a variant the file runs
    for (const std::string& name : fc.skip_variants) {
      if (std::none_of(c.variants.begin(), c.variants.end(), [&](const PlantVariant& v) { return v.name == name; })) {
        root.fail("cases", fmt::format("case '{}' skips variant '{}', which is not among the variants run", fc.name, name));
      }
    }
  }
  root.finish();
  return c;
}

FalseAlarmResult judge_false_alarms(const FalseAlarmConfig& config, std::vector<FalseAlarmRow> rows) {
  FalseAlarmResult result;
  result.rows = std::move(rows);
  for (std::size_t g = 0; g < config.noise_scales.size(); ++g) {
    FalseAlarmGroup group;
    group.noise_scale = config.noise_scales[g];
    group.judged = g <= 1;
    group.margin_judged = g == 0;
    double run_s = 0;
    std::size_t runs = 0;
    for (const FalseAlarmRow& r : result.rows) {
      if (r.noise_scale != group.noise_scale) continue;
      group.hours += r.duration_s / 3600.0;
      run_s += r.duration_s;
      ++runs;
    }
    run_s = runs ? run_s / static_cast<double>(runs) : 0.0;
    for (int i = 0; i < safety::kFaultFlagCount; ++i) {
      CheckStatistics s;
      s.flag = 1u << i;
      std::vector<double> peaks;
      for (const FalseAlarmRow& r : result.rows) {
        if (r.noise_scale != group.noise_scale) continue;
        const double ratio = r.peaks[static_cast<std::size_t>(i)];
        s.trips += r.first_flag == s.flag;
        s.later += r.first_flag != s.flag && (r.flags & s.flag) != 0;
        if (ratio <= 0) continue;  // never above 0 (or never evaluated): counted as 0 below
        peaks.push_back(ratio);
        if (ratio > s.max_ratio) s.max_ratio = ratio, s.worst = worst_of(r);
      }
      s.runs = runs;
      // The law is fitted to the runs where the check compared anything above 0.
      const double fitted = runs ? gumbel_rate_per_h(peaks, run_s) * static_cast<double>(peaks.size()) / static_cast<double>(runs) : 0.0;
      const double observed = group.hours > 0 ? static_cast<double>(s.trips) / group.hours : 0.0;
      s.rate_per_h = std::max(fitted, observed);
      peaks.resize(runs, 0.0);  // the runs where it never compared above 0
      s.p99_ratio = quantile(peaks, 0.99);
      const std::string name = safety::fault_flag_name(s.flag);
      if (group.judged && s.trips > 0) result.failures.push_back(fmt::format("{} x{:g}: {} trip(s)", name, group.noise_scale, s.trips));
      if (group.margin_judged && s.max_ratio * config.margin_goal > 1.0 && s.trips == 0) {
        result.failures.push_back(fmt::format("{} x{:g}: margin {:.2f} < {:g} (peak {:.3f} x threshold, {})", name, group.noise_scale,
                                              s.margin(), config.margin_goal, s.max_ratio, s.worst));
      }
      group.checks.push_back(s);
    }
    result.groups.push_back(std::move(group));
  }
  return result;
}

FalseAlarmResult run_false_alarms(const FalseAlarmConfig& config,
                                  const std::function<void(std::size_t, std::size_t, const std::string&)>& progress) {
  const std::vector<AlarmRun> jobs = false_alarm_jobs(config);
  std::vector<std::vector<FalseAlarmRow>> rows_of(jobs.size());
  std::size_t done = 0;
  std::mutex report;
  run_job_pool(jobs.size(), config.threads, [&](std::size_t i) {
    const AlarmRun& job = jobs[i];
    std::vector<FalseAlarmRow> rows;
    switch (job.what->run) {
      case FalseAlarmRun::kE1: rows = run_e1(config, job); break;
      case FalseAlarmRun::kPostures: rows = run_postures_job(config, job); break;
      case FalseAlarmRun::kGoniometer: rows = run_goniometer_job(config, job); break;
    }
    const std::lock_guard lock(report);
    const std::size_t n = ++done;
    if (progress) {
      std::string line;
      for (const FalseAlarmRow& r : rows) {
        double peak = 0;
        std::uint32_t peak_flag = 0;
        for (int k = 0; k < safety::kFaultFlagCount; ++k) {
          if (r.peaks[static_cast<std::size_t>(k)] > peak) peak = r.peaks[static_cast<std::size_t>(k)], peak_flag = 1u << k;
        }
        line += fmt::format("{}{} {} x{:g} seed {}: largest {} {:.2f}, {}", line.empty() ? "" : "; ", r.case_name, r.variant,
                            r.noise_scale, r.seed, safety::fault_flag_name(peak_flag), peak,
                            r.first_flag ? fmt::format("FALSE ALARM {}", safety::fault_flag_name(r.first_flag)) : "no trip");
      }
      progress(n, jobs.size(), line);
    }
    rows_of[i] = std::move(rows);
  });
  std::vector<FalseAlarmRow> rows;
  for (auto& r : rows_of) rows.insert(rows.end(), r.begin(), r.end());
  return judge_false_alarms(config, std::move(rows));
}

void write_false_alarms(const std::filesystem::path& dir, const FalseAlarmConfig& config, const FalseAlarmResult& result) {
  std::ofstream csv(dir / "false_alarms.csv");
  csv << "case,variant,noise_scale,seed,duration_s,flags,first_flag";
  for (const safety::CheckInfo& c : safety::kChecks) csv << "," << c.name;
  csv << "\n";
  for (const FalseAlarmRow& r : result.rows) {
    csv << fmt::format("{},{},{:g},{},{:g},{},{}", r.case_name, r.variant, r.noise_scale, r.seed, r.duration_s, r.flags,
                       r.first_flag ? safety::fault_flag_name(r.first_flag) : "-");
    for (double p : r.peaks) csv << fmt::format(",{:.5g}", p);
    csv << "\n";
  }
  std::ofstream md(dir / "false_alarms.md");
  md << "# False alarms of the plausibility monitor\n\n";
  std::string cases;
  for (const FalseAlarmCase& c : config.cases) cases += fmt::format("{}{} ({}, `{}`)", cases.empty() ? "" : ", ", c.name, run_key(c.run), c.scenario.filename().string());
  md << fmt::format("Fault-free runs: {}; sensor noise x{}; seeds 1..{} each; plant variants of the robustness matrix at x1 noise, "
                    "seeds 1..{} each ({} variants). {} runs.\n\n",
                    cases, fmt::format("{}", fmt::join(config.noise_scales, ", x")), config.seeds, config.variant_seeds, config.variants.size(),
                    result.rows.size());
  md << fmt::format("Ratio: the quantity a check compares with its threshold, divided by the threshold (its largest value over a run; "
                    "a check on a floor: floor / value). Margin = 1 / the largest ratio. Verdict: at x{:g} (nominal and variants) no trip and "
                    "every margin >= {:g}; at x{:g} no trip. Rate: false alarms per hour, a Gumbel law fitted by moments to the runs' "
                    "peak ratios (P(peak >= 1) per run's duration), or the observed trips per hour when larger.\n\n",
                    config.noise_scales.front(), config.margin_goal, config.noise_scales.size() > 1 ? config.noise_scales[1] : 0.0);
  md << (result.passed() ? "**Verdict: PASSED**\n\n" : "**Verdict: FAILED**: ");
  for (std::size_t i = 0; i < result.failures.size(); ++i) md << (i ? "; " : "") << result.failures[i];
  if (!result.passed()) md << "\n\n";
  for (const FalseAlarmGroup& g : result.groups) {
    md << fmt::format("## Sensor noise x{:g}{} ({:.2f} h simulated{})\n\n", g.noise_scale, g.noise_scale == 1 ? " and the plant variants" : "",
                      g.hours, g.margin_judged ? ": trips and margins judged" : g.judged ? ": trips judged" : ": reported");
    md << "| check | safe state | runs | false alarms (first fault) | latched after one | largest ratio | 99th percentile | margin | "
          "false alarms / h | worst run |\n|---|---|---|---|---|---|---|---|---|---|\n";
    for (const CheckStatistics& s : g.checks) {
      if (s.runs == 0 && s.trips == 0 && s.later == 0) continue;
      md << fmt::format("| {} | {} | {} | {} | {} | {:.3f} | {:.3f} | {} | {:.2g} | {} |\n", safety::fault_flag_name(s.flag),
                        safety::safe_action_name(safety::safe_action(s.flag)), s.runs, s.trips, s.later, s.max_ratio, s.p99_ratio,
                        s.max_ratio > 0 ? fmt::format("{:.2f}", s.margin()) : "-", s.rate_per_h, s.worst);
    }
    md << "\n";
  }
  md << "Checks not listed compared nothing in these runs (non-finite values, the e-stop; sensors a backend lacks).\n";
}

}  // namespace peha::experiments
