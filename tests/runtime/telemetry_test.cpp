#include "peha/runtime/telemetry.hpp"

#include "../support/telemetry_receiver.hpp"

#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cmath>
#include <limits>
#include <set>
#include <string>
#include <vector>

namespace peha::runtime {
namespace {

using Receiver = testing::TelemetryReceiver;

// Counts the `"key":` entries of the innermost object of one datagram.
std::vector<std::string> keys_of_group(const std::string& json, const std::string& group) {
  std::vector<std::string> keys;
  std::size_t p = json.find("\"" + group + "\":{");
  if (p == std::string::npos) return keys;
  p += group.size() + 4;
  while (p < json.size() && json[p] == '"') {
    const std::size_t end = json.find("\":", p + 1);
    keys.push_back(json.substr(p + 1, end - p - 1));
    p = json.find_first_of(",}", end);
    if (json[p] == '}') break;
    ++p;
  }
  return keys;
}

TEST(Telemetry, SendsPlotJugglerJsonToAUdpPort) {
  Receiver rx;
  Telemetry tm("127.0.0.1", rx.port(), 100.0, "exo", {"angle_rad", "force_N", "p_MPa"});
  const double values[] = {0.25, -3.0, 1.5e-7};
  tm.publish(1.5, values);
  EXPECT_EQ(rx.receive(), R"({"timestamp":1.500000,"exo":{"angle_rad":0.25,"force_N":-3,"p_MPa":1.5e-07}})");
  ASSERT_TRUE(tm.flush());
  EXPECT_EQ(tm.sent_datagrams(), 1u);
  EXPECT_EQ(tm.send_errors(), 0u);
}

// JSON has no NaN or infinity; PlotJuggler's parser throws on them and stops its server.
TEST(Telemetry, SendsNonFiniteValuesAsNull) {
  Receiver rx;
  Telemetry tm("127.0.0.1", rx.port(), 100.0, "exo", {"a", "b", "c"});
  const double values[] = {std::nan(""), std::numeric_limits<double>::infinity(), 2.0};
  tm.publish(0.0, values);
  EXPECT_EQ(rx.receive(), R"({"timestamp":0.000000,"exo":{"a":null,"b":null,"c":2}})");
}

// A 1 kHz loop publishing for 1 s (1001 calls, t = 0 .. 1 s) at rate 100 Hz: 101 samples (t = 0,
// 0.01, ..., 1.00) reach the socket, 10 ms apart in loop time.
TEST(Telemetry, DecimatesToItsRate) {
  Receiver rx;
  Telemetry tm("127.0.0.1", rx.port(), 100.0, "exo", {"k"});
  for (int k = 0; k <= 1000; ++k) {
    const double value = k;
    tm.publish(k * 1e-3, {&value, 1});
  }
  ASSERT_TRUE(tm.flush());
  EXPECT_EQ(tm.published_samples(), 101u);
  EXPECT_EQ(tm.dropped_samples(), 0u);
  EXPECT_EQ(tm.sent_datagrams(), 101u);
  for (int i = 0; i <= 100; ++i) {
    const std::string d = rx.receive();
    ASSERT_FALSE(d.empty()) << "datagram " << i;
    EXPECT_EQ(d, "{\"timestamp\":" + std::to_string(i * 0.01) + ",\"exo\":{\"k\":" + std::to_string(10 * i) + "}}");
  }
  EXPECT_TRUE(rx.nothing_more(50));
}

// 100 signals with 40-character names make ~5.5 kB of JSON: it goes out as several datagrams of at
// most 1400 bytes, each a complete object with the same timestamp, carrying every signal once.
TEST(Telemetry, SplitsLargeSamplesIntoDatagramsBelowTheMtu) {
  Receiver rx;
  std::vector<std::string> names;
  std::vector<double> values;
  for (int i = 0; i < 100; ++i) {
    names.push_back("right_arm_joint_signal_with_a_long_name_" + std::to_string(100 + i));
    values.push_back(-1234.56789 * i);
  }
  Telemetry tm("127.0.0.1", rx.port(), 100.0, "arm", names);
  tm.publish(2.0, values);
  ASSERT_TRUE(tm.flush());
  const std::uint64_t datagrams = tm.sent_datagrams();
  EXPECT_GE(datagrams, 4u);
  EXPECT_LE(datagrams, 6u);
  std::multiset<std::string> seen;
  for (std::uint64_t i = 0; i < datagrams; ++i) {
    const std::string d = rx.receive();
    ASSERT_FALSE(d.empty());
    EXPECT_LE(d.size(), Telemetry::kMaxDatagramBytes);
    EXPECT_EQ(d.rfind("{\"timestamp\":2.000000,\"arm\":{", 0), 0u) << d;
    EXPECT_EQ(d.substr(d.size() - 2), "}}");
    for (const std::string& k : keys_of_group(d, "arm")) seen.insert(k);
  }
  EXPECT_EQ(seen.size(), 100u);
  EXPECT_EQ(std::set<std::string>(seen.begin(), seen.end()), std::set<std::string>(names.begin(), names.end()));
}

TEST(Telemetry, EscapesNamesForJson) {
  Receiver rx;
  Telemetry tm("127.0.0.1", rx.port(), 100.0, "exo", {"say \"hi\"\\"});
  const double v = 1.0;
  tm.publish(0.0, {&v, 1});
  EXPECT_EQ(rx.receive(), R"({"timestamp":0.000000,"exo":{"say \"hi\"\\":1}})");
}

TEST(Telemetry, CountsSamplesItCannotQueue) {
  Receiver rx;
  Telemetry tm("127.0.0.1", rx.port(), 1e6, "exo", {"a", "b"});
  const double one[] = {1.0};
  tm.publish(0.0, one);  // wrong width
  EXPECT_EQ(tm.dropped_samples(), 1u);
  EXPECT_EQ(tm.published_samples(), 0u);
}

TEST(Telemetry, RejectsBadArguments) {
  EXPECT_THROW(Telemetry("localhost", 9870, 100, "g", {"a"}), std::invalid_argument);  // not a dotted quad
  EXPECT_THROW(Telemetry("127.0.0.1", 0, 100, "g", {"a"}), std::invalid_argument);
  EXPECT_THROW(Telemetry("127.0.0.1", 9870, 0, "g", {"a"}), std::invalid_argument);
  EXPECT_THROW(Telemetry("127.0.0.1", 9870, 100, "g", {}), std::invalid_argument);
  EXPECT_THROW(Telemetry("127.0.0.1", 9870, 100, "", {"a"}), std::invalid_argument);
  EXPECT_THROW(Telemetry("127.0.0.1", 9870, 100, "g", {std::string(300, 'x')}), std::invalid_argument);
}

// Issue 11: telemetry (the wearer's forces and angles, unencrypted) stays on this machine unless
// a remote destination is allowed explicitly.
TEST(Telemetry, StaysOnLoopbackUnlessARemoteDestinationIsAllowed) {
  try {
    Telemetry("192.0.2.7", 9870, 100, "g", {"a"});
    ADD_FAILURE() << "a non-loopback destination was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("not a loopback address"), std::string::npos) << e.what();
  }
  EXPECT_THROW(Telemetry("0.0.0.0", 9870, 100, "g", {"a"}), std::invalid_argument);
  EXPECT_NO_THROW(Telemetry("127.0.0.2", 9870, 100, "g", {"a"}));
  EXPECT_NO_THROW(Telemetry("192.0.2.7", 9870, 100, "g", {"a"}, 256, /*allow_non_loopback=*/true));
}

}  // namespace
}  // namespace peha::runtime
