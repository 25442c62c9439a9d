// `peha keygen`: a fresh link key per installation (docs/commissioning.md), in the format
// mfb::load_link_key reads.
#include "peha/app/commands.hpp"
#include "peha/mfb/link_config.hpp"

#include <fmt/format.h>

namespace peha::app {

int keygen(const std::filesystem::path& out) {
  try {
    mfb::write_new_link_key(out);
    fmt::print("peha keygen: wrote a new 32-byte link key to {} (mode 0600). Name it in the scenario's mfb: key_file, and give the board "
               "the same key; keep it off the repository.\n",
               out.string());
    return 0;
  } catch (const std::exception& e) {
    fmt::print(stderr, "{}\n", e.what());
    return 2;
  }
}

}  // namespace peha::app
