#include "peha/video/offscreen.hpp"

#include <EGL/egl.h>
#include <EGL/eglext.h>
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include <fmt/format.h>

#include <chrono>
#include <cstdlib>
#include <fcntl.h>
#include <filesystem>
#include <signal.h>
#include <spawn.h>
#include <stdexcept>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>

extern char** environ;

namespace peha::video {
namespace {

using GetString = const unsigned char* (*)(unsigned int);
constexpr unsigned int kGlVersion = 0x1F02, kGlRenderer = 0x1F01;  // GL_VERSION, GL_RENDERER

std::string gl_strings(void* get_string) {
  if (!get_string) return "OpenGL ?";
  const auto f = reinterpret_cast<GetString>(get_string);
  const auto* version = f(kGlVersion);
  const auto* renderer = f(kGlRenderer);
  return fmt::format("OpenGL {} {}", version ? reinterpret_cast<const char*>(version) : "?",
                     renderer ? reinterpret_cast<const char*>(renderer) : "?");
}

std::string glfw_error() {
  const char* text = nullptr;
  glfwGetError(&text);
  return text ? text : "unknown GLFW error";
}

/// Starts `Xvfb :N` on the first free display number (no shell); waits for its socket. -1 if none.
pid_t start_xvfb(int& display, std::string& why) {
  for (int n = 99; n < 120; ++n) {
    if (std::filesystem::exists(fmt::format("/tmp/.X{}-lock", n)) ||
        std::filesystem::exists(fmt::format("/tmp/.X11-unix/X{}", n))) {
      continue;
    }
    const std::string name = fmt::format(":{}", n);
    const char* argv[] = {"Xvfb", name.c_str(), "-screen", "0", "1280x1024x24", "-nolisten", "tcp", nullptr};
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, "/dev/null", O_WRONLY, 0);
    posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, "/dev/null", O_WRONLY, 0);
    pid_t pid = -1;
    const int rc = posix_spawnp(&pid, "Xvfb", &actions, nullptr, const_cast<char* const*>(argv), environ);
    posix_spawn_file_actions_destroy(&actions);
    if (rc != 0) {
      why = "Xvfb could not be started (not installed? apt-get install xvfb)";
      return -1;
    }
    for (int i = 0; i < 100; ++i) {  // up to 5 s for the server's socket
      if (std::filesystem::exists(fmt::format("/tmp/.X11-unix/X{}", n))) {
        display = n;
        return pid;
      }
      int status = 0;
      if (waitpid(pid, &status, WNOHANG) == pid) break;  // it exited (display taken meanwhile?)
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    kill(pid, SIGTERM);
    waitpid(pid, nullptr, 0);
  }
  why = "Xvfb did not come up on any display :99..:119";
  return -1;
}

}  // namespace

const char* to_string(GlBackend b) noexcept { return b == GlBackend::kEgl ? "EGL" : "GLFW"; }

OffscreenContext::OffscreenContext(const std::string& prefer) {
  std::string choice = prefer;
  if (const char* env = std::getenv("PEHA_GL"); env && *env) choice = env;
  if (choice != "auto" && choice != "egl" && choice != "glfw") {
    throw std::runtime_error(fmt::format("unknown OpenGL backend '{}' (auto, egl or glfw)", choice));
  }
  std::string why_egl = "not tried", why_glfw = "not tried";
  if ((choice == "auto" || choice == "egl") && try_egl(why_egl)) return;
  if ((choice == "auto" || choice == "glfw") && try_glfw(why_glfw)) return;
  release();  // e.g. an Xvfb started for a GLFW window that then failed
  throw std::runtime_error(fmt::format("no OpenGL context for offscreen rendering: EGL: {}; GLFW: {}", why_egl, why_glfw));
}

bool OffscreenContext::try_egl(std::string& why) {
  EGLDisplay display = EGL_NO_DISPLAY;
  std::string platform = "default display";
  // Mesa's surfaceless platform needs neither X nor a GPU device (llvmpipe renders in software).
  const auto get_platform_display =
      reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(eglGetProcAddress("eglGetPlatformDisplayEXT"));
  if (get_platform_display) {
    display = get_platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
    platform = "Mesa surfaceless";
  }
  EGLint major = 0, minor = 0;
  if (display == EGL_NO_DISPLAY || !eglInitialize(display, &major, &minor)) {
    display = eglGetDisplay(EGL_DEFAULT_DISPLAY);
    platform = "default display";
    if (display == EGL_NO_DISPLAY || !eglInitialize(display, &major, &minor)) {
      why = fmt::format("no EGL display (eglInitialize error 0x{:x})", eglGetError());
      return false;
    }
  }
  // EGL_SURFACE_TYPE defaults to EGL_WINDOW_BIT, which a surfaceless display has none of.
  const EGLint attributes[] = {EGL_SURFACE_TYPE, EGL_PBUFFER_BIT, EGL_RED_SIZE, 8, EGL_GREEN_SIZE, 8, EGL_BLUE_SIZE, 8, EGL_DEPTH_SIZE, 24,
                               EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_NONE};
  EGLConfig config = nullptr;
  EGLint count = 0;
  if (!eglChooseConfig(display, attributes, &config, 1, &count) || count < 1) {
    why = fmt::format("{}: no config with 8-bit RGB, 24-bit depth and desktop OpenGL", platform);
    eglTerminate(display);
    return false;
  }
  if (!eglBindAPI(EGL_OPENGL_API)) {
    why = fmt::format("{}: desktop OpenGL not available", platform);
    eglTerminate(display);
    return false;
  }
  EGLContext context = eglCreateContext(display, config, EGL_NO_CONTEXT, nullptr);
  if (context == EGL_NO_CONTEXT || !eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, context)) {
    why = fmt::format("{}: no surfaceless context (error 0x{:x})", platform, eglGetError());
    if (context != EGL_NO_CONTEXT) eglDestroyContext(display, context);
    eglTerminate(display);
    return false;
  }
  egl_display_ = display;
  egl_context_ = context;
  backend_ = GlBackend::kEgl;
  description_ = fmt::format("EGL {}.{} ({}), {}", major, minor, platform,
                             gl_strings(reinterpret_cast<void*>(eglGetProcAddress("glGetString"))));
  return true;
}

bool OffscreenContext::try_glfw(std::string& why) {
  const char* display = std::getenv("DISPLAY");
  std::string server = display && *display ? fmt::format("DISPLAY={}", display) : "";
  if (server.empty()) {
    int n = -1;
    xvfb_pid_ = start_xvfb(n, why);
    if (xvfb_pid_ < 0) {
      why = "DISPLAY is not set and " + why;
      return false;
    }
    setenv("DISPLAY", fmt::format(":{}", n).c_str(), 1);
    server = fmt::format("Xvfb :{} started by peha", n);
  }
  if (!glfwInit()) {
    why = fmt::format("{}: glfwInit failed: {}", server, glfw_error());
    return false;
  }
  glfwWindowHint(GLFW_VISIBLE, GLFW_FALSE);
  glfwWindowHint(GLFW_DOUBLEBUFFER, GLFW_FALSE);
  GLFWwindow* window = glfwCreateWindow(64, 64, "peha video", nullptr, nullptr);
  if (!window) {
    why = fmt::format("{}: no hidden window: {}", server, glfw_error());
    glfwTerminate();
    return false;
  }
  glfwMakeContextCurrent(window);
  glfw_window_ = window;
  backend_ = GlBackend::kGlfw;
  description_ = fmt::format("GLFW hidden window ({}), {}", server,
                             gl_strings(reinterpret_cast<void*>(glfwGetProcAddress("glGetString"))));
  return true;
}

OffscreenContext::~OffscreenContext() { release(); }

void OffscreenContext::release() noexcept {
  if (egl_context_) {
    eglMakeCurrent(egl_display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    eglDestroyContext(egl_display_, egl_context_);
    eglTerminate(egl_display_);
    egl_context_ = egl_display_ = nullptr;
  }
  if (glfw_window_) {
    glfwDestroyWindow(static_cast<GLFWwindow*>(glfw_window_));
    glfwTerminate();
    glfw_window_ = nullptr;
  }
  if (xvfb_pid_ > 0) {
    kill(xvfb_pid_, SIGTERM);
    waitpid(xvfb_pid_, nullptr, 0);
    unsetenv("DISPLAY");
    xvfb_pid_ = -1;
  }
}

}  // namespace peha::video
