#include "peha/video/clip.hpp"

#include "peha/video/ffmpeg_encoder.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <memory>
#include <stdexcept>

namespace peha::video {
namespace {

struct DataDeleter {
  void operator()(mjData* d) const noexcept { mj_deleteData(d); }
};

/// MuJoCo's scene, context, camera and the inset figure for one model; renders one frame into `rgb`.
class Renderer {
 public:
  Renderer(mjModel* model, const ClipOptions& o) : model_(model), o_(o), data_(mj_makeData(model)) {
    if (o.width <= 0 || o.height <= 0 || o.width % 2 || o.height % 2) {
      throw std::runtime_error(fmt::format("video size {}x{}: width and height must be even and > 0", o.width, o.height));
    }
    // The offscreen buffer is sized from the model (set before the context is made).
    model_->vis.global.offwidth = std::max(model_->vis.global.offwidth, o.width);
    model_->vis.global.offheight = std::max(model_->vis.global.offheight, o.height);
    mjv_defaultScene(&scene_);
    mjv_makeScene(model_, &scene_, 2000);
    mjv_defaultOption(&option_);
    mjv_defaultCamera(&camera_);
    camera_.type = mjCAMERA_FREE;
    for (int i = 0; i < 3; ++i) camera_.lookat[i] = o.lookat[static_cast<std::size_t>(i)];
    camera_.distance = o.distance_m;
    camera_.azimuth = o.azimuth_deg;
    camera_.elevation = o.elevation_deg;
    mjr_defaultContext(&context_);
    mjr_makeContext(model_, &context_, mjFONTSCALE_100);
    mjr_setBuffer(mjFB_OFFSCREEN, &context_);
    if (context_.currentBuffer != mjFB_OFFSCREEN) throw std::runtime_error("MuJoCo: no offscreen framebuffer in this context");
    figure_ = std::make_unique<mjvFigure>();
    mjv_defaultFigure(figure_.get());
    rgb_.resize(static_cast<std::size_t>(o.width) * static_cast<std::size_t>(o.height) * 3);
  }
  ~Renderer() {
    mjr_freeContext(&context_);
    mjv_freeScene(&scene_);
  }
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  /// Renders time t; returns the frame, top row first.
  const std::vector<unsigned char>& render(double t, const FrameSetter& set) {
    frame_.arrows.clear();
    frame_.muscles.clear();
    frame_.overlay_names.clear();
    frame_.overlay_values.clear();
    data_->time = t;
    set(t, data_.get(), frame_);
    mj_kinematics(model_, data_.get());
    mj_comPos(model_, data_.get());
    mjv_updateScene(model_, data_.get(), &option_, nullptr, &camera_, mjCAT_ALL, &scene_);
    add_machine_geoms(model_, data_.get(), o_.machine.kind, o_.machine.supply_pressure_MPa, frame_.muscles, scene_);
    for (const Arrow& a : frame_.arrows) add_arrow(a);
    if (o_.machine.kind != MachineKind::kNone) add_key_light();
    const mjrRect viewport{0, 0, o_.width, o_.height};
    mjr_render(viewport, &scene_, &context_);
    if (o_.machine.kind != MachineKind::kNone) draw_pressure_legend();
    if (!o_.inset.empty()) draw_inset(t);
    mjr_overlay(mjFONT_NORMAL, mjGRID_TOPLEFT, viewport, frame_.overlay_names.c_str(), frame_.overlay_values.c_str(), &context_);
    if (!o_.title.empty()) mjr_overlay(mjFONT_BIG, mjGRID_TOPRIGHT, viewport, o_.title.c_str(), nullptr, &context_);
    mjr_readPixels(rgb_.data(), nullptr, viewport, &context_);
    flip();
    return rgb_;
  }

 private:
  void add_arrow(const Arrow& a) {
    const double length = std::hypot(a.to[0] - a.from[0], a.to[1] - a.from[1], a.to[2] - a.from[2]);
    if (scene_.ngeom >= scene_.maxgeom || length < 1e-6) return;
    mjvGeom* g = scene_.geoms + scene_.ngeom;
    mjv_initGeom(g, mjGEOM_ARROW, nullptr, nullptr, nullptr, a.rgba.data());
    mjv_makeConnector(g, mjGEOM_ARROW, a.width_m, a.from[0], a.from[1], a.from[2], a.to[0], a.to[1], a.to[2]);
    g->category = mjCAT_DECOR;
    ++scene_.ngeom;
  }

  /// A light from above, in front and to the camera's left, as in a lab under ceiling lights; the
  /// headlight stays as a fill.
  void add_key_light() {
    if (scene_.nlight >= mjMAXLIGHT) return;
    mjvLight& l = scene_.lights[scene_.nlight++];
    l = mjvLight{};
    const double az = camera_.azimuth * M_PI / 180;
    const double d[3] = {std::cos(az) + 0.5 * std::sin(az), std::sin(az) - 0.5 * std::cos(az), -1.6};
    const double n = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    for (int k = 0; k < 3; ++k) {
      l.dir[k] = static_cast<float>(d[k] / n);
      l.pos[k] = static_cast<float>(camera_.lookat[k] - 4 * d[k] / n);
      l.ambient[k] = 0.1f;
      l.diffuse[k] = 0.6f;
      l.specular[k] = 0.2f;
    }
    l.attenuation[0] = 1;
    l.cutoff = 180;
    l.directional = 1;
    l.castshadow = 0;  // a shadow map costs llvmpipe three to four times the frame
  }

  /// The muscles' colour scale, 0 .. supply, bottom left.
  void draw_pressure_legend() {
    constexpr int kSteps = 24, kBarW = 240, kBarH = 14, kX = 12, kY = 34;
    for (int i = 0; i < kSteps; ++i) {
      const auto c = pressure_rgba(o_.machine.supply_pressure_MPa * (i + 0.5) / kSteps, o_.machine.supply_pressure_MPa);
      mjr_rectangle(mjrRect{kX + i * kBarW / kSteps, kY, kBarW / kSteps + 1, kBarH}, c[0], c[1], c[2], 1);
    }
    const std::string top = fmt::format("{:.1f} MPa", o_.machine.supply_pressure_MPa);
    mjr_overlay(mjFONT_NORMAL, mjGRID_BOTTOMLEFT, mjrRect{kX - 6, kY - 30, kBarW, 30}, "0", nullptr, &context_);
    mjr_overlay(mjFONT_NORMAL, mjGRID_BOTTOMRIGHT, mjrRect{kX, kY - 30, kBarW + 6, 30}, top.c_str(), nullptr, &context_);
    mjr_overlay(mjFONT_NORMAL, mjGRID_BOTTOMLEFT, mjrRect{kX - 6, kY + kBarH - 4, kBarW, 30}, "muscle pressure", nullptr, &context_);
  }

  /// The inset: each series over [t - window, t], bottom right.
  void draw_inset(double t) {
    mjvFigure& f = *figure_;
    mjv_defaultFigure(&f);
    f.flg_legend = 1;
    f.flg_extend = 1;
    f.figurergba[3] = 0.6f;
    f.gridsize[0] = 3;
    f.gridsize[1] = 3;
    f.range[0][0] = static_cast<float>(t - o_.inset_window_s);
    f.range[0][1] = static_cast<float>(std::max(t, o_.inset_window_s * 1e-3));
    std::snprintf(f.title, sizeof f.title, "%s", o_.inset_title.c_str());
    std::snprintf(f.xlabel, sizeof f.xlabel, "t / s");
    std::snprintf(f.xformat, sizeof f.xformat, "%%.0f");
    std::snprintf(f.yformat, sizeof f.yformat, "%%.0f");
    const int lines = std::min<int>(static_cast<int>(o_.inset.size()), mjMAXLINE);
    for (int l = 0; l < lines; ++l) {
      const Series& s = o_.inset[static_cast<std::size_t>(l)];
      std::snprintf(f.linename[l], sizeof f.linename[l], "%s", s.name.c_str());
      for (int c = 0; c < 3; ++c) f.linergb[l][c] = s.rgb[static_cast<std::size_t>(c)];
      const auto& ts = *s.t_s;
      const auto& ys = *s.values;
      const auto first = std::lower_bound(ts.begin(), ts.end(), t - o_.inset_window_s) - ts.begin();
      const auto last = std::upper_bound(ts.begin(), ts.end(), t) - ts.begin();
      const auto n = std::max<std::ptrdiff_t>(last - first, 0);
      const std::ptrdiff_t stride = std::max<std::ptrdiff_t>(1, (n + mjMAXLINEPNT - 1) / mjMAXLINEPNT);
      int p = 0;
      for (std::ptrdiff_t i = first; i < last && p < mjMAXLINEPNT; i += stride) {
        const double y = ys[static_cast<std::size_t>(i)];
        if (!std::isfinite(y)) continue;
        f.linedata[l][2 * p] = static_cast<float>(ts[static_cast<std::size_t>(i)]);
        f.linedata[l][2 * p + 1] = static_cast<float>(y);
        ++p;
      }
      f.linepnt[l] = p;
    }
    const int w = o_.width * 2 / 5, h = o_.height * 2 / 5;
    mjr_figure(mjrRect{o_.width - w, 0, w, h}, &f, &context_);
  }

  void flip() {
    const std::size_t row = static_cast<std::size_t>(o_.width) * 3;
    for (int y = 0; y < o_.height / 2; ++y) {
      std::swap_ranges(rgb_.begin() + static_cast<std::ptrdiff_t>(y * row), rgb_.begin() + static_cast<std::ptrdiff_t>((y + 1) * row),
                       rgb_.begin() + static_cast<std::ptrdiff_t>((o_.height - 1 - y) * row));
    }
  }

  mjModel* model_;
  ClipOptions o_;
  std::unique_ptr<mjData, DataDeleter> data_;
  mjvScene scene_;
  mjvOption option_;
  mjvCamera camera_;
  mjrContext context_;
  std::unique_ptr<mjvFigure> figure_;
  Frame frame_;
  std::vector<unsigned char> rgb_;
};

}  // namespace

ClipStats render_clip(mjModel* model, double duration_s, const FrameSetter& set, const ClipOptions& options,
                      const std::filesystem::path& mp4, const OffscreenContext&) {
  const auto start = std::chrono::steady_clock::now();
  Renderer renderer(model, options);
  FfmpegEncoder encoder(mp4, options.width, options.height, options.fps);
  const double step_s = options.speed / options.fps;
  const int frames = std::max(1, static_cast<int>(std::llround(duration_s / step_s)));  // frame i shows t = i * step
  for (int i = 0; i < frames; ++i) encoder.write_frame(renderer.render(i * step_s, set).data());
  encoder.finish();
  ClipStats s;
  s.frames = frames;
  s.duration_s = static_cast<double>(frames) / options.fps;
  s.render_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  s.bytes = std::filesystem::file_size(mp4);
  return s;
}

std::vector<std::vector<unsigned char>> render_frames(mjModel* model, const std::vector<double>& times_s,
                                                      const FrameSetter& set, const ClipOptions& options,
                                                      const OffscreenContext&) {
  Renderer renderer(model, options);
  std::vector<std::vector<unsigned char>> out;
  for (double t : times_s) out.push_back(renderer.render(t, set));
  return out;
}

}  // namespace peha::video
