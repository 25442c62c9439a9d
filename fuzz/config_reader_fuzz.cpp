// libFuzzer target: the strict config reader (config::Document / config::Map) on arbitrary text.
// Every input either loads or throws config::Error; nothing else may escape, crash or leak.
// Walks whatever mapping it gets with every reader method, as a scenario reader would.
#include "peha/config/reader.hpp"

#include <cstddef>
#include <cstdint>
#include <string>

namespace {

void walk(peha::config::Map map, int depth) {
  using peha::config::Error;
  if (depth > 8) return;
  for (const char* key : {"a", "b", "seed", "experiment", "list", "x", "0"}) {
    try { map.number(key, {-1e9, 1e9}); } catch (const Error&) {}
    try { map.integer(key, -1000, 1000); } catch (const Error&) {}
    try { map.string(key); } catch (const Error&) {}
    try { map.boolean(key); } catch (const Error&) {}
    try { map.choice(key, {"a", "b"}); } catch (const Error&) {}
    try { map.numbers(key, {-1e9, 1e9}, 0, 64); } catch (const Error&) {}
    try { walk(map.map(key), depth + 1); } catch (const Error&) {}
    try {
      for (peha::config::Map item : map.maps(key, 0, 64)) walk(item, depth + 1);
    } catch (const Error&) {}
  }
  try { map.finish(); } catch (const Error&) {}
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    peha::config::Document doc = peha::config::Document::load_string(text, "fuzz.yaml");
    walk(doc.root(), 0);
  } catch (const peha::config::Error&) {
  }
  return 0;
}
