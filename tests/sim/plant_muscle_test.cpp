// Tests of the simulated plant's muscle law (include/peha/sim/plant_muscle.hpp) against the real
// Festo maps and its contract with the simulator (finite, >= 0, monotone, C1, hysteresis sign).
#include "peha/sim/plant_muscle.hpp"
#include "peha/calibration/dataset.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

namespace peha::sim {
namespace {

const std::string kDmsp40Yaml = PEHA_SOURCE_DIR "/configs/plant/dmsp40.yaml";
const std::string kDmsp10Yaml = PEHA_SOURCE_DIR "/configs/plant/dmsp10.yaml";
const std::string kPamData = PEHA_SHARED_DATA_DIR "/pam/";

// Error bounds stated in docs/plant-muscle.md (a little above the fitted values, so a refit that
// gets worse fails here).
constexpr double kDmsp40RmsBound_N = 35.0;
constexpr double kDmsp40MaxBound_N = 100.0;
constexpr double kDmsp10RmsBound_N = 2.5;
constexpr double kDmsp10MaxBound_N = 7.0;
constexpr double kMartens10RmsBound_N = 25.0;
constexpr double kMartens10MaxBound_N = 50.0;

struct MapPoint {
  double pressure_Pa;
  double contraction;
  double force_N;
};

// Reads a force map: '#' lines are comments, the first other line is the header.
std::vector<MapPoint> read_map(const std::string& path, const std::string& pressure_column,
                               double pressure_scale_Pa) {
  std::ifstream in(path);
  EXPECT_TRUE(in) << "cannot open " << path;
  std::vector<std::string> header;
  std::vector<MapPoint> points;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::vector<std::string> cells;
    std::stringstream ss(line);
    for (std::string cell; std::getline(ss, cell, ',');) cells.push_back(cell);
    if (header.empty()) {
      header = cells;
      continue;
    }
    auto column = [&](const std::string& name) {
      const auto it = std::find(header.begin(), header.end(), name);
      EXPECT_NE(it, header.end()) << path << ": no column " << name;
      return std::stod(cells.at(static_cast<std::size_t>(it - header.begin())));
    };
    points.push_back({column(pressure_column) * pressure_scale_Pa, column("contraction"),
                      column("force_N")});
  }
  EXPECT_FALSE(points.empty()) << path;
  return points;
}

struct FitError {
  double rms_N = 0.0;
  double max_N = 0.0;
};

// Non-positive map forces are "cannot pull" points: the target there is 0 N (as in the fitter).
FitError fit_error(const PlantMuscleParams& law, const std::vector<MapPoint>& map) {
  FitError e;
  double sum_sq = 0.0;
  for (const MapPoint& m : map) {
    const double r = static_force_N(law, m.pressure_Pa, m.contraction) - std::max(m.force_N, 0.0);
    sum_sq += r * r;
    e.max_N = std::max(e.max_N, std::abs(r));
  }
  e.rms_N = std::sqrt(sum_sq / static_cast<double>(map.size()));
  return e;
}

std::string read_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

std::vector<PlantMuscleParams> both_laws() {
  return {load_plant_muscle(kDmsp40Yaml), load_plant_muscle(kDmsp10Yaml)};
}

TEST(PlantMuscle, LoadsGeneratedConfigs) {
  const PlantMuscleParams p40 = load_plant_muscle(kDmsp40Yaml);
  const PlantMuscleParams p10 = load_plant_muscle(kDmsp10Yaml);
  EXPECT_EQ(p40.name, "DMSP-40");
  EXPECT_EQ(p10.name, "DMSP-10");
  EXPECT_GT(p40.gain_N_per_Pa, p10.gain_N_per_Pa);
  EXPECT_GE(p40.max_pressure_Pa, 0.8e6);  // the supply must not be clamped away
  EXPECT_GE(p10.max_pressure_Pa, 0.8e6);
}

TEST(PlantMuscle, FitsFestoDmsp40MapWithinStatedError) {
  const auto map =
      read_map(kPamData + "festo_datasheet_DMSP-40_digitized.csv", "pressure_kPa", 1e3);
  const FitError e = fit_error(load_plant_muscle(kDmsp40Yaml), map);
  EXPECT_LT(e.rms_N, kDmsp40RmsBound_N);
  EXPECT_LT(e.max_N, kDmsp40MaxBound_N);
}

// The law's ceiling bounds the forces a calibration CSV of this muscle may hold (peha calibrate
// --scenario): above every force of the muscle's own datasheet map (DMSP-40: 9331 N at 0.62 MPa,
// stretched 5 %), and the DMSP-40 law at 1.2 MPa is what the reader allows where no muscle is known.
TEST(PlantMuscle, CeilingHoldsTheWholeDatasheetMapAndIsTheReadersBoundForAnyMuscle) {
  for (const auto& [yaml, csv] : {std::pair{kDmsp40Yaml, "festo_datasheet_DMSP-40_digitized.csv"},
                                  std::pair{kDmsp10Yaml, "festo_datasheet_DMSP-10_digitized.csv"}}) {
    const PlantMuscleParams law = load_plant_muscle(yaml);
    double largest_N = 0;
    for (const MapPoint& m : read_map(kPamData + csv, "pressure_kPa", 1e3)) largest_N = std::max(largest_N, m.force_N);
    const double ceiling_N = force_ceiling_N(law);
    EXPECT_GT(ceiling_N, largest_N) << law.name;
    // Not a loose bound: the law's 1 MPa clamp is 1.25-1.6 x the maps' top pressure (DMSP-40 14.5 kN
    // for 9331 N, DMSP-10 1.13 kN for 645 N).
    EXPECT_LT(ceiling_N, 2.0 * largest_N) << law.name;
  }
  PlantMuscleParams at_reader_ceiling = load_plant_muscle(kDmsp40Yaml);
  at_reader_ceiling.max_pressure_Pa = calibration::kMaxPlausiblePressure_MPa * 1e6;
  at_reader_ceiling.hysteresis_fraction = 0;
  const double physics_N = force_ceiling_N(at_reader_ceiling);
  // The reader's bound scales the map linearly in pressure; the law bends slightly below (16.1 kN).
  EXPECT_GE(calibration::kAnyMuscleMaxForce_N, physics_N);
  EXPECT_LE(calibration::kAnyMuscleMaxForce_N, 1.15 * physics_N);
}

TEST(PlantMuscle, FitsFestoDmsp10MapWithinStatedError) {
  const auto map =
      read_map(kPamData + "festo_datasheet_DMSP-10_digitized.csv", "pressure_kPa", 1e3);
  const FitError e = fit_error(load_plant_muscle(kDmsp10Yaml), map);
  EXPECT_LT(e.rms_N, kDmsp10RmsBound_N);
  EXPECT_LT(e.max_N, kDmsp10MaxBound_N);
}

TEST(PlantMuscle, Dmsp10LawAgreesWithIndependentMartensMapWithinStatedError) {
  const auto map = read_map(kPamData + "martens2017_DMSP-10-250_forcemap.csv", "pressure_Pa", 1.0);
  const FitError e = fit_error(load_plant_muscle(kDmsp10Yaml), map);
  EXPECT_LT(e.rms_N, kMartens10RmsBound_N);
  EXPECT_LT(e.max_N, kMartens10MaxBound_N);
}

TEST(PlantMuscle, NoForceBelowThePressureThreshold) {
  const PlantMuscleParams p40 = load_plant_muscle(kDmsp40Yaml);
  const PlantMuscleParams p10 = load_plant_muscle(kDmsp10Yaml);
  EXPECT_LT(static_force_N(p40, 0.0, 0.1), 1e-3);
  EXPECT_LT(static_force_N(p40, 100e3, 0.25), 1.0);    // datasheet: -155 N, i.e. cannot pull
  EXPECT_GT(static_force_N(p40, 300e3, 0.25), 200.0);  // datasheet: 311 N
  EXPECT_LT(static_force_N(p10, 100e3, 0.1), 1e-3);
  EXPECT_LT(static_force_N(p10, 200e3, 0.1), 1.0);
}

TEST(PlantMuscle, LargePassiveForceWhenStretchedEvenWithoutPressure) {
  const PlantMuscleParams p40 = load_plant_muscle(kDmsp40Yaml);
  EXPECT_NEAR(static_force_N(p40, 0.0, -0.05), 2141.0, 150.0);  // datasheet at 0 kPa
  EXPECT_GT(static_force_N(p40, 0.0, -0.03), 500.0);
  const PlantMuscleParams p10 = load_plant_muscle(kDmsp10Yaml);
  EXPECT_NEAR(static_force_N(p10, 0.0, -0.03), 232.4, 20.0);
}

TEST(PlantMuscle, ForceVanishesNearMaximumContractionEvenAtSupplyPressure) {
  const PlantMuscleParams p40 = load_plant_muscle(kDmsp40Yaml);
  const PlantMuscleParams p10 = load_plant_muscle(kDmsp10Yaml);
  EXPECT_LT(static_force_N(p40, 0.8e6, 0.40), 1.0);
  EXPECT_LT(static_force_N(p10, 0.8e6, 0.30), 1.0);
}

TEST(PlantMuscle, AnalyticContractionDerivativeMatchesCentralDifferences) {
  for (const PlantMuscleParams& p : both_laws()) {
    for (double P = 0.0; P <= 1.0e6; P += 50e3) {
      for (double u = -0.3; u <= 0.6; u += 0.0037) {
        const double h = 1e-6;
        const double numeric =
            (static_force_N(p, P, u + h) - static_force_N(p, P, u - h)) / (2.0 * h);
        const double analytic = static_force_dcontraction_N(p, P, u);
        EXPECT_NEAR(analytic, numeric, 1e-5 * (1.0 + std::abs(analytic)))
            << p.name << " P=" << P << " u=" << u;
      }
    }
  }
}

TEST(PlantMuscle, ContinuouslyDifferentiableAcrossTheElasticKnee) {
  for (const PlantMuscleParams& p : both_laws()) {
    const double uk = p.elastic_knee_contraction;
    for (double P : {0.0, 300e3, 800e3}) {
      const double e = 1e-9;
      EXPECT_NEAR(static_force_N(p, P, uk - e), static_force_N(p, P, uk + e), 1e-3);
      const double left = static_force_dcontraction_N(p, P, uk - e);
      const double right = static_force_dcontraction_N(p, P, uk + e);
      EXPECT_NEAR(left, right, 1e-6 * std::abs(left)) << p.name << " P=" << P;
    }
  }
}

TEST(PlantMuscle, ForceIsFiniteAndNonNegativeForAnyInput) {
  const double inf = std::numeric_limits<double>::infinity();
  const std::vector<double> pressures = {-inf, -1e12, -1e5, 0.0,   1e3, 2e5,
                                         8e5,  1e6,   5e6,  1e300, inf};
  const std::vector<double> rates = {-inf, -1e9, -1.0, 0.0, 0.01, 1.0, 1e9, inf};
  for (const PlantMuscleParams& p : both_laws()) {
    for (double P : pressures) {
      for (double u = -1.0; u <= 2.0; u += 0.01) {
        const double F = static_force_N(p, P, u);
        EXPECT_TRUE(std::isfinite(F) && F >= 0.0) << p.name << " P=" << P << " u=" << u;
        EXPECT_TRUE(std::isfinite(static_force_dcontraction_N(p, P, u)));
        for (double rate : rates) {
          const double Fh = force_N(p, P, u, rate);
          EXPECT_TRUE(std::isfinite(Fh) && Fh >= 0.0) << p.name << " P=" << P << " u=" << u;
        }
      }
      for (double u : {-inf, -1e300, 1e300, inf}) {
        EXPECT_TRUE(std::isfinite(static_force_N(p, P, u)) && static_force_N(p, P, u) >= 0.0);
        EXPECT_EQ(static_force_dcontraction_N(p, P, u), 0.0);
      }
    }
  }
}

TEST(PlantMuscle, NanInputGivesZeroForce) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const PlantMuscleParams p = load_plant_muscle(kDmsp40Yaml);
  EXPECT_EQ(static_force_N(p, nan, 0.1), 0.0);
  EXPECT_EQ(static_force_N(p, 3e5, nan), 0.0);
  EXPECT_EQ(static_force_dcontraction_N(p, nan, 0.1), 0.0);
  EXPECT_EQ(static_force_dcontraction_N(p, 3e5, nan), 0.0);
  EXPECT_EQ(force_N(p, nan, 0.1, 0.0), 0.0);
  EXPECT_EQ(force_N(p, 3e5, nan, 0.0), 0.0);
  // A NaN rate only loses the hysteresis, not the force.
  EXPECT_EQ(force_N(p, 3e5, 0.1, nan), static_force_N(p, 3e5, 0.1));
}

TEST(PlantMuscle, ForceDecreasesWithContractionAndNeverFallsWithPressure) {
  for (const PlantMuscleParams& p : both_laws()) {
    for (double P = 0.0; P <= 1.2e6; P += 20e3) {
      double previous = static_force_N(p, P, -1.0);
      for (double u = -0.999; u <= 1.0; u += 0.001) {
        const double F = static_force_N(p, P, u);
        // Strictly where the force is resolvable in double precision, never increasing anywhere.
        if (previous > 1e-6) {
          EXPECT_LT(F, previous) << p.name << " P=" << P << " u=" << u;
        } else {
          EXPECT_LE(F, previous) << p.name << " P=" << P << " u=" << u;
        }
        EXPECT_LE(static_force_dcontraction_N(p, P, u), 0.0);
        EXPECT_GE(static_force_N(p, P + 20e3, u), F) << p.name << " P=" << P << " u=" << u;
        previous = F;
      }
    }
  }
}

TEST(PlantMuscle, HysteresisLowersForceWhenContractingAndRaisesItWhenExtending) {
  const PlantMuscleParams p = load_plant_muscle(kDmsp40Yaml);
  const double P = 3e5;
  const double u = 0.1;
  const double F0 = static_force_N(p, P, u);
  ASSERT_GT(F0, 100.0);
  EXPECT_DOUBLE_EQ(force_N(p, P, u, 0.0), F0);
  const double contracting = force_N(p, P, u, 0.2);
  const double extending = force_N(p, P, u, -0.2);
  EXPECT_LT(contracting, F0);
  EXPECT_GT(extending, F0);
  // Fully developed (|rate| >> rate scale), the loop is 2h wide.
  EXPECT_NEAR(force_N(p, P, u, 1e3), F0 * (1.0 - p.hysteresis_fraction), 1e-9 * F0);
  EXPECT_NEAR(force_N(p, P, u, -1e3), F0 * (1.0 + p.hysteresis_fraction), 1e-9 * F0);
  // Continuous through zero velocity.
  EXPECT_NEAR(force_N(p, P, u, 1e-9), F0, 1e-6 * F0);
}

TEST(PlantMuscle, RejectsConfigWithUnknownKey) {
  const std::string text = read_text(kDmsp40Yaml) + "spring_constant_N: 3\n";
  config::Map root = config::Document::load_string(text, "dmsp40-bad.yaml").root();
  try {
    read_plant_muscle(root);
    FAIL() << "unknown key accepted";
  } catch (const config::Error& e) {
    EXPECT_NE(std::string(e.what()).find("spring_constant_N"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("unknown key"), std::string::npos) << e.what();
  }
}

TEST(PlantMuscle, RejectsConfigWithOutOfRangeValue) {
  std::string text = read_text(kDmsp40Yaml);
  const std::string key = "hysteresis_fraction:";
  const std::size_t at = text.find(key);
  ASSERT_NE(at, std::string::npos);
  text.replace(at, text.find('\n', at) - at, key + " 0.9");
  config::Map root = config::Document::load_string(text, "dmsp40-bad.yaml").root();
  try {
    read_plant_muscle(root);
    FAIL() << "out-of-range value accepted";
  } catch (const config::Error& e) {
    EXPECT_NE(std::string(e.what()).find("hysteresis_fraction"), std::string::npos) << e.what();
  }
}

TEST(PlantMuscle, RejectsPressureCurvatureThatWouldMakeForceFallWithPressure) {
  std::string text = read_text(kDmsp40Yaml);
  using KeyValue = std::pair<std::string, std::string>;
  for (const auto& [key, value] :
       {KeyValue{"pressure_curvature_per_MPa:", " -0.4"}, KeyValue{"max_pressure_Pa:", " 2.0e6"}}) {
    const std::size_t at = text.find(key);
    ASSERT_NE(at, std::string::npos);
    text.replace(at, text.find('\n', at) - at, key + value);
  }
  config::Map root = config::Document::load_string(text, "dmsp40-bad.yaml").root();
  EXPECT_THROW(read_plant_muscle(root), config::Error);
}

TEST(PlantMuscle, RejectsConfigWithMissingKey) {
  config::Map root = config::Document::load_string("name: DMSP-40\ngain_N_per_Pa: 0.01\n").root();
  EXPECT_THROW(read_plant_muscle(root), config::Error);
}

// The law skips libm where the rounded result is known (softplus(x) = x from x > 34, tanh = +-1 from
// |x| >= 20): the forces must be those of the law written out with every libm call, bit for bit,
// since the simulated plants' figures are asserted to that (docs/performance.md).
double textbook_force_N(const PlantMuscleParams& p, double pressure_Pa, double u, double rate) {
  auto softplus = [](double x) { return std::max(x, 0.0) + std::log1p(std::exp(-std::abs(x))); };
  if (std::isnan(pressure_Pa) || std::isnan(u)) return 0.0;
  u = std::clamp(u, kMinContraction, kMaxContraction);
  const double P = std::clamp(pressure_Pa, 0.0, std::max(p.max_pressure_Pa, 0.0));
  const double q_Pa = P * (1.0 + p.pressure_curvature_per_MPa * P / 1.0e6);
  const double um = std::max(p.gain_zero_contraction, 1e-12);
  const double w = std::max(p.gain_smoothing_contraction, 1e-12);
  const double d = w * softplus((um - u) / w) / um;
  const double c = std::clamp(p.gain_quadratic_fraction, 0.0, 1.0);
  const double s = ((1.0 - c) + c * d) * d;
  const double kappa = std::max(p.gain_saturation, 0.0);
  const double g = p.gain_N_per_Pa * (1.0 + kappa) * s / (1.0 + kappa * s);
  const double ue = std::max(p.elastic_contraction_scale, 1e-12);
  const double uk = p.elastic_knee_contraction;
  const double E = u >= uk ? std::exp(-u / ue) : std::exp(-uk / ue) * (1.0 - (u - uk) / ue);
  const double z = g * q_Pa + (p.elastic_force_N * (E - 1.0) - p.elastic_stiffness_N * u);
  const double delta = std::max(p.threshold_smoothing_N, 1e-12);
  const double h = std::clamp(p.hysteresis_fraction, 0.0, 1.0);
  const double factor = 1.0 - h * std::tanh(rate / std::max(p.hysteresis_rate_scale_1ps, 1e-12));
  return delta * softplus(z / delta) * factor;
}

TEST(PlantMuscle, ForceIsTheTextbookLawBitForBit) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> pressure(-1e5, 1.1e6), contraction(-1.2, 0.6), rate(-3.0, 3.0);
  for (const PlantMuscleParams& p : {load_plant_muscle(kDmsp40Yaml), load_plant_muscle(kDmsp10Yaml)}) {
    for (int n = 0; n < 200000; ++n) {
      const double P = pressure(rng), u = contraction(rng), r = n % 4 == 0 ? 0.0 : rate(rng);
      const double expected = textbook_force_N(p, P, u, r);
      const double got = force_N(p, P, u, r);
      ASSERT_EQ(std::memcmp(&expected, &got, sizeof got), 0) << p.name << " P " << P << " u " << u << " rate " << r
                                                             << ": " << got << " vs " << expected;
    }
  }
}

}  // namespace
}  // namespace peha::sim
