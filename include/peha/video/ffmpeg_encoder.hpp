#pragma once
/// \file
/// An MP4 writer: ffmpeg spawned without a shell (posix_spawnp), raw RGB frames piped to its stdin,
/// H.264 (libx264, yuv420p) at a fixed frame rate (docs/video.md).

#include <cstdint>
#include <filesystem>
#include <string>
#include <sys/types.h>

namespace peha::video {

class FfmpegEncoder {
 public:
  /// Starts `ffmpeg` writing `path`; frames are `width` x `height` RGB24, top row first. Throws
  /// std::runtime_error when ffmpeg cannot be started (not installed: apt-get install ffmpeg).
  /// Sets SIGPIPE to ignored in the process, so that a write to an ffmpeg that exited throws
  /// instead of killing peha.
  FfmpegEncoder(const std::filesystem::path& path, int width, int height, int fps);
  ~FfmpegEncoder();
  FfmpegEncoder(const FfmpegEncoder&) = delete;
  FfmpegEncoder& operator=(const FfmpegEncoder&) = delete;

  /// Appends one frame of width * height * 3 bytes. Throws if ffmpeg stopped reading.
  void write_frame(const std::uint8_t* rgb);
  /// Closes the pipe and waits for ffmpeg; throws with its exit status if it failed.
  void finish();
  int frames() const noexcept { return frames_; }

 private:
  std::filesystem::path path_;
  int width_, height_;
  int frames_ = 0;
  int pipe_fd_ = -1;
  pid_t pid_ = -1;
};

}  // namespace peha::video
