// The simulated hardware's lifecycle (sim::OutputGate): the outages the fault matrix plays in process.
#include "peha/sim/output_gate.hpp"

#include <gtest/gtest.h>

namespace peha::sim {
namespace {

io::Command one_joint(double pressure_Pa) {
  io::Command c;
  c.joint_count = 1;
  c.joints[0].agonist_pressure_Pa = pressure_Pa;
  c.joints[0].motor_torque_Nm = 1.0;
  return c;
}

// A lost uplink of 2.5 s at 1 kHz: exactly 2500 samples never reach the host, and the outputs go on
// following the commands meanwhile (the board still hears the host).
TEST(OutputGate, AStateLossMissesExactlyItsSamplesAndTheOutputsFollow) {
  OutputGate gate(1e-3, 2.0);
  gate.activate();
  gate.lose_samples(2.5);
  int missed = 0;
  for (int k = 0; k < 4000; ++k) {
    const io::Command& applied = gate.apply(one_joint(3e5));
    EXPECT_DOUBLE_EQ(applied.joints[0].agonist_pressure_Pa, 3e5);
    missed += !gate.samples();
  }
  EXPECT_EQ(missed, 2500);
  EXPECT_TRUE(gate.status().active);
  EXPECT_FALSE(gate.status().rebooted);
}

// A board off for 2.5 s: no samples, its outputs vent (motor off), it cannot be armed; back, it says
// it restarted and stays disarmed until the host deactivates and re-arms it.
TEST(OutputGate, ARebootedBoardVentsIsSilentAndStaysDisarmedUntilReArmed) {
  OutputGate gate(1e-3, 2.0);
  gate.activate();
  gate.apply(one_joint(3e5));
  gate.reboot(2.5);  // as a plant's write(): the fault first, then this period's outputs
  int missed = 0;
  for (int k = 0; k < 2500; ++k) {
    gate.apply(one_joint(3e5));
    missed += !gate.samples();
    gate.activate();  // refused while the board is off
  }
  EXPECT_EQ(missed, 2500);
  const io::Command& vented = gate.apply(one_joint(3e5));
  EXPECT_TRUE(gate.samples());
  EXPECT_DOUBLE_EQ(vented.joints[0].agonist_pressure_Pa, 0.0);  // 2.5 s of a 2 s vent
  EXPECT_DOUBLE_EQ(vented.joints[0].motor_torque_Nm, 0.0);
  EXPECT_FALSE(gate.status().active);
  EXPECT_TRUE(gate.status().rebooted);
  EXPECT_TRUE(gate.status().ready_to_arm);
  gate.deactivate();
  EXPECT_FALSE(gate.status().rebooted);
  gate.activate();
  EXPECT_TRUE(gate.status().active);
}

}  // namespace
}  // namespace peha::sim
