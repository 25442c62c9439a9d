#include "peha/video/ffmpeg_encoder.hpp"

#include <fmt/format.h>

#include <cerrno>
#include <csignal>
#include <cstring>
#include <fcntl.h>
#include <spawn.h>
#include <stdexcept>
#include <sys/wait.h>
#include <unistd.h>
#include <vector>

extern char** environ;

namespace peha::video {

FfmpegEncoder::FfmpegEncoder(const std::filesystem::path& path, int width, int height, int fps)
    : path_(path), width_(width), height_(height) {
  // A writer to a closed pipe must get EPIPE, not die of SIGPIPE.
  std::signal(SIGPIPE, SIG_IGN);
  int fds[2];
  if (pipe2(fds, O_CLOEXEC) != 0) throw std::runtime_error(fmt::format("pipe: {}", std::strerror(errno)));
  const std::string size = fmt::format("{}x{}", width, height), rate = std::to_string(fps), out = path.string();
  // yuv420p for players everywhere; +faststart puts the index first; 2 threads (the machine is shared).
  const std::vector<std::string> args = {"ffmpeg", "-hide_banner", "-loglevel", "error", "-y", "-f", "rawvideo",
                                         "-pix_fmt", "rgb24", "-s", size, "-r", rate, "-i", "pipe:0",
                                         "-an", "-c:v", "libx264", "-preset", "veryfast", "-crf", "23",
                                         "-pix_fmt", "yuv420p", "-threads", "2", "-movflags", "+faststart", out};
  std::vector<char*> argv;
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, fds[0], STDIN_FILENO);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, "/dev/null", O_WRONLY, 0);
  const int rc = posix_spawnp(&pid_, "ffmpeg", &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  close(fds[0]);
  if (rc != 0) {
    close(fds[1]);
    pid_ = -1;
    throw std::runtime_error(fmt::format("cannot start ffmpeg ({}): apt-get install ffmpeg", std::strerror(rc)));
  }
  pipe_fd_ = fds[1];
}

void FfmpegEncoder::write_frame(const std::uint8_t* rgb) {
  std::size_t left = static_cast<std::size_t>(width_) * static_cast<std::size_t>(height_) * 3;
  while (left > 0) {
    const ssize_t n = ::write(pipe_fd_, rgb, left);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) throw std::runtime_error(fmt::format("ffmpeg stopped reading frames for {}", path_.string()));
    rgb += n;
    left -= static_cast<std::size_t>(n);
  }
  ++frames_;
}

void FfmpegEncoder::finish() {
  if (pipe_fd_ >= 0) close(pipe_fd_);
  pipe_fd_ = -1;
  if (pid_ < 0) return;
  int status = 0;
  while (waitpid(pid_, &status, 0) < 0 && errno == EINTR) {}
  pid_ = -1;
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    throw std::runtime_error(fmt::format("ffmpeg failed writing {} (status {})", path_.string(), status));
  }
}

FfmpegEncoder::~FfmpegEncoder() {
  if (pipe_fd_ >= 0) close(pipe_fd_);
  if (pid_ > 0) waitpid(pid_, nullptr, 0);
}

}  // namespace peha::video
