#include "peha/experiments/e1_gravity/e1_gravity.hpp"
#include "peha/runtime/csv_log.hpp"
#include "peha/safety/fault_monitor.hpp"
#include "../support/shipped_scenarios.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

namespace peha::experiments {
namespace {

/// The plant's (truth) largest joint speed over a run, from E1's log rows.
class PeakSpeed final : public runtime::RowSink {
 public:
  PeakSpeed()
      : t_(column("t_s")), angle_(column("plant_angle_rad")) {}
  void push_row(std::span<const double> row) noexcept override {
    if (has_) peak_degps_ = std::max(peak_degps_, std::abs(row[angle_] - last_rad_) / (row[t_] - last_t_s_) * 180.0 / M_PI);
    last_rad_ = row[angle_], last_t_s_ = row[t_], has_ = true;
  }
  double peak_degps() const { return peak_degps_; }

 private:
  static std::size_t column(const char* name) {
    const auto& c = e1_log_columns();
    return static_cast<std::size_t>(std::find(c.begin(), c.end(), name) - c.begin());
  }
  std::size_t t_, angle_;
  double last_rad_ = 0, last_t_s_ = 0, peak_degps_ = 0;
  bool has_ = false;
};

// Issue 29, "a false alarm can hurt": E1 with 5 kg and 10x pressure-sensor noise (seed 7) raised a
// false pressure_rise at 4.4 s, which vented: when the finger let go of the pushed link at 9.2 s
// it fell at 395 deg/s onto its stop. Noise can trip that check, so its safe state lowers the link
// governed instead: the link stays inside its range and below the 90 deg/s that make a falling link
// (joint_speed). Measured 57.7 deg/s, as the governor catches the link the finger lets go at 9.2 s:
// the 30 deg/s of issue 29 is not met yet.
TEST(FalseAlarmSafeState, TenfoldPressureNoiseNoLongerDropsTheLink) {
  const E1Scenario s = peha::test_support::shipped_e1();
  const E1Case& c = s.cases.at(1);
  ASSERT_EQ(c.payload_kg, 5.0);
  sim::OneDofRigParams p = e1_plant_params(s, c);
  p.pressure_noise_Pa *= 10.0;
  p.seed = 7;
  sim::OneDofRigBackend plant(p);
  PeakSpeed speed;
  const E1Result r = run_e1_on(s, c, plant, &plant, &speed);
  EXPECT_NE(r.fault_flags & safety::kFaultPressureRise, 0u) << r.fault_reason;  // the false alarm still latches
  EXPECT_LE(speed.peak_degps(), 90.0) << r.fault_reason;
  EXPECT_GE(r.min_angle_deg, -46.2);  // inside the range (its lower end -46.15 deg)
}

}  // namespace
}  // namespace peha::experiments
