#pragma once
/// \file
/// `peha run --video`: after the run, one MP4 per case log beside the CSV (video/run_videos.hpp).

#include "peha/config/reader.hpp"

#include <filesystem>
#include <string>

namespace peha::app {

/// Renders the videos of the run in `dir` of scenario `doc` (experiment key `experiment`). Prints
/// what it wrote; when no OpenGL context or ffmpeg is available it says so clearly and returns
/// false (the run's other outputs are already written). Never throws.
bool write_run_videos(const config::Document& doc, const std::string& experiment, const std::filesystem::path& dir);

}  // namespace peha::app
