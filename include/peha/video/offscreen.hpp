#pragma once
/// \file
/// An OpenGL context for offscreen rendering by MuJoCo, without a window on screen (docs/video.md).
///
/// Tried in order: EGL (Mesa's surfaceless platform or the default display: no X server at all),
/// then a hidden GLFW window on $DISPLAY, starting an Xvfb server first when DISPLAY is unset.
/// Whatever is found is made current on the calling thread. Set-up only: it may fail, and then says
/// why each way failed (the run goes on without video).

#include <memory>
#include <string>
#include <sys/types.h>

namespace peha::video {

/// Which way the context was made.
enum class GlBackend { kEgl, kGlfw };

const char* to_string(GlBackend b) noexcept;

class OffscreenContext {
 public:
  /// Makes a context current, or throws std::runtime_error naming each way tried and why it failed.
  /// `prefer`: "auto" (EGL, then GLFW), "egl" or "glfw" (PEHA_GL in the environment overrides it).
  explicit OffscreenContext(const std::string& prefer = "auto");
  ~OffscreenContext();
  OffscreenContext(const OffscreenContext&) = delete;
  OffscreenContext& operator=(const OffscreenContext&) = delete;

  GlBackend backend() const noexcept { return backend_; }
  /// e.g. "EGL 1.4 (Mesa surfaceless), OpenGL 4.5 (Core Profile) Mesa 22.3.6 llvmpipe".
  const std::string& description() const noexcept { return description_; }

 private:
  bool try_egl(std::string& why);
  bool try_glfw(std::string& why);
  void release() noexcept;

  GlBackend backend_ = GlBackend::kEgl;
  std::string description_;
  void* egl_display_ = nullptr;
  void* egl_context_ = nullptr;
  void* glfw_window_ = nullptr;
  pid_t xvfb_pid_ = -1;  ///< the Xvfb this context started (stopped again in the destructor)
};

}  // namespace peha::video
