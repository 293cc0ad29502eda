#include "render.hpp"

#include <fcntl.h>
#include <mujoco/mujoco.h>
#include <poll.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "process.hpp"
#include "rollstep/common/interrupt.hpp"

#ifdef ROLLSTEP_HAVE_OSMESA
#include <GL/osmesa.h>
#include <lodepng.h>
#endif

namespace rollstep::experiments {

#ifdef ROLLSTEP_HAVE_OSMESA

struct Renderer::Impl {
  OSMesaContext context = nullptr;
  std::vector<unsigned char> buffer;  // OSMesa's RGBA colour buffer
  mjModel* model = nullptr;
  mjData* data = nullptr;
  mjvScene scene{};
  mjrContext gl{};
  mjvCamera camera{};
  mjvOption option{};
  int width = 0, height = 0;
  std::vector<std::pair<std::string, int>> joints;  // log column -> qpos address
  int base_qpos = 0;
  bool scene_made = false, gl_made = false;

  ~Impl() {
    if (gl_made) mjr_freeContext(&gl);
    if (scene_made) mjv_freeScene(&scene);
    if (data != nullptr) mj_deleteData(data);
    if (model != nullptr) mj_deleteModel(model);
    if (context != nullptr) OSMesaDestroyContext(context);
  }
};

bool Renderer::available(std::string& reason) {
  reason.clear();
  return true;
}

Renderer::Renderer(const sim::Plant& plant, int width, int height, bool fast)
    : impl_(std::make_unique<Impl>()) {
  Impl& r = *impl_;
  r.width = width;
  r.height = height;
  r.context = OSMesaCreateContextExt(OSMESA_RGBA, 24, 8, 0, nullptr);
  if (r.context == nullptr) throw std::runtime_error("OSMesa could not create a context");
  r.buffer.assign(static_cast<std::size_t>(width) * static_cast<std::size_t>(height) * 4, 0);
  if (!OSMesaMakeCurrent(r.context, r.buffer.data(), GL_UNSIGNED_BYTE, width, height)) {
    throw std::runtime_error("OSMesa could not make its context current");
  }
  r.model = mj_copyModel(nullptr, plant.mujocoModel());
  if (r.model == nullptr) throw std::runtime_error("MuJoCo could not copy the model");
  r.model->vis.global.offwidth = width;
  r.model->vis.global.offheight = height;
  r.model->vis.quality.shadowsize = 2048;
  r.data = mj_makeData(r.model);
  mjv_defaultOption(&r.option);
  mjv_defaultCamera(&r.camera);
  mjv_defaultScene(&r.scene);
  mjr_defaultContext(&r.gl);
  mjv_makeScene(r.model, &r.scene, 2000);
  r.scene_made = true;
  if (fast) {
    r.scene.flags[mjRND_SHADOW] = 0;
    r.scene.flags[mjRND_REFLECTION] = 0;
  }
  mjr_makeContext(r.model, &r.gl, mjFONTSCALE_100);
  r.gl_made = true;
  mjr_setBuffer(mjFB_OFFSCREEN, &r.gl);
  if (r.gl.currentBuffer != mjFB_OFFSCREEN) {
    throw std::runtime_error("MuJoCo has no offscreen buffer in this OpenGL context");
  }
  r.camera.type = mjCAMERA_FREE;
  r.camera.distance = 2.6;
  r.camera.azimuth = 240.0;  // from the robot's left, a little ahead
  r.camera.elevation = -18.0;
  for (int j = 0; j < r.model->njnt; ++j) {
    const char* name = mj_id2name(r.model, mjOBJ_JOINT, j);
    if (name == nullptr) continue;
    const std::string n(name);
    if (r.model->jnt_type[j] == mjJNT_FREE) r.base_qpos = r.model->jnt_qposadr[j];
    const char* unit = r.model->jnt_type[j] == mjJNT_SLIDE ? "[m]" : "[rad]";
    r.joints.emplace_back("q_" + n + unit, r.model->jnt_qposadr[j]);
  }
  mj_forward(r.model, r.data);
}

Renderer::~Renderer() = default;

Image Renderer::render(const LogTable& log, std::size_t row, const std::string& label) {
  Impl& r = *impl_;
  OSMesaMakeCurrent(r.context, r.buffer.data(), GL_UNSIGNED_BYTE, r.width, r.height);
  static const char* const kBase[7] = {"base_x[m]",  "base_y[m]",  "base_z[m]", "base_qw[-]",
                                       "base_qx[-]", "base_qy[-]", "base_qz[-]"};
  for (int k = 0; k < 7; ++k) r.data->qpos[r.base_qpos + k] = log.column(kBase[k])[row];
  for (const auto& [column, address] : r.joints) {
    if (log.has(column)) r.data->qpos[address] = log.column(column)[row];
  }
  mj_kinematics(r.model, r.data);
  mj_camlight(r.model, r.data);
  for (int k = 0; k < 3; ++k) r.camera.lookat[k] = r.data->qpos[r.base_qpos + k];
  r.camera.lookat[2] -= 0.1;
  mjv_updateScene(r.model, r.data, &r.option, nullptr, &r.camera, mjCAT_ALL, &r.scene);
  const mjrRect viewport{0, 0, r.width, r.height};
  mjr_render(viewport, &r.scene, &r.gl);
  if (!label.empty())
    mjr_overlay(mjFONT_NORMAL, mjGRID_TOPLEFT, viewport, label.c_str(), nullptr, &r.gl);
  Image image;
  image.width = r.width;
  image.height = r.height;
  std::vector<unsigned char> bottom_up(static_cast<std::size_t>(r.width) *
                                       static_cast<std::size_t>(r.height) * 3);
  mjr_readPixels(bottom_up.data(), nullptr, viewport, &r.gl);
  image.rgb.resize(bottom_up.size());
  const std::size_t stride = static_cast<std::size_t>(r.width) * 3;
  for (int y = 0; y < r.height; ++y) {
    std::memcpy(image.rgb.data() + static_cast<std::size_t>(y) * stride,
                bottom_up.data() + static_cast<std::size_t>(r.height - 1 - y) * stride, stride);
  }
  return image;
}

void writePng(const std::string& path, const Image& image) {
  const unsigned error = lodepng::encode(path, image.rgb, static_cast<unsigned>(image.width),
                                         static_cast<unsigned>(image.height), LCT_RGB, 8);
  if (error != 0) {
    throw std::runtime_error("cannot write '" + path + "': " + lodepng_error_text(error));
  }
}

#else  // no OSMesa

struct Renderer::Impl {};

bool Renderer::available(std::string& reason) {
  reason =
      "this rollstep was built without OSMesa (install libosmesa6-dev and liblodepng-dev, "
      "then rebuild)";
  return false;
}

Renderer::Renderer(const sim::Plant&, int, int, bool) {
  std::string reason;
  available(reason);
  throw std::runtime_error(reason);
}

Renderer::~Renderer() = default;

Image Renderer::render(const LogTable&, std::size_t, const std::string&) { return {}; }

void writePng(const std::string& path, const Image&) {
  throw std::runtime_error("cannot write '" + path + "': built without lodepng");
}

#endif

Image tile(const std::vector<Image>& frames, int columns) {
  Image out;
  if (frames.empty() || columns < 1) return out;
  const int w = frames[0].width, h = frames[0].height;
  const int n = static_cast<int>(frames.size());
  const int rows = (n + columns - 1) / columns;
  out.width = w * std::min(columns, n);
  out.height = h * rows;
  out.rgb.assign(static_cast<std::size_t>(out.width) * static_cast<std::size_t>(out.height) * 3,
                 255);
  for (int i = 0; i < n; ++i) {
    const Image& f = frames[static_cast<std::size_t>(i)];
    if (f.width != w || f.height != h) continue;
    const int x0 = (i % columns) * w, y0 = (i / columns) * h;
    for (int y = 0; y < h; ++y) {
      std::memcpy(out.rgb.data() + (static_cast<std::size_t>(y0 + y) * out.width + x0) * 3,
                  f.rgb.data() + static_cast<std::size_t>(y) * w * 3,
                  static_cast<std::size_t>(w) * 3);
    }
  }
  return out;
}

VideoWriter::VideoWriter(const std::string& path, int width, int height, int fps, double time_limit)
    : path_(path),
      log_path_(path + ".ffmpeg.txt"),
      width_(width),
      height_(height),
      deadline_(std::chrono::steady_clock::now() +
                std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                    std::chrono::duration<double>(time_limit))),
      time_limit_(time_limit) {
  if (!onPath("ffmpeg")) {
    throw std::runtime_error("ffmpeg is not installed (Debian package ffmpeg)");
  }
  // A broken pipe (ffmpeg died) must be an error of this writer, not a signal that kills us.
  std::signal(SIGPIPE, SIG_IGN);
  const std::vector<std::string> args = {"-y",
                                         "-loglevel",
                                         "error",
                                         "-f",
                                         "rawvideo",
                                         "-pix_fmt",
                                         "rgb24",
                                         "-s",
                                         std::to_string(width) + "x" + std::to_string(height),
                                         "-r",
                                         std::to_string(fps),
                                         "-i",
                                         "-",
                                         "-c:v",
                                         "libx264",
                                         "-preset",
                                         "veryfast",
                                         "-crf",
                                         "26",
                                         "-pix_fmt",
                                         "yuv420p",
                                         "-threads",
                                         "1",
                                         path};
  // ffmpeg as a child of its own (not popen): its frames written with a time limit, and
  // ended if it stops taking them, or on an interrupt.
  int fds[2] = {-1, -1};
  if (::pipe2(fds, O_CLOEXEC) != 0) {
    throw std::runtime_error("cannot start ffmpeg: " + std::string(std::strerror(errno)));
  }
  std::vector<std::string> argv_text{"ffmpeg"};
  argv_text.insert(argv_text.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& a : argv_text) argv.push_back(a.data());
  argv.push_back(nullptr);
  const int log = ::open(log_path_.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  std::fflush(nullptr);
  pid_ = ::fork();
  if (pid_ == 0) {
    ::dup2(fds[0], 0);
    if (log >= 0) {
      ::dup2(log, 1);
      ::dup2(log, 2);
    }
    ::execvp("ffmpeg", argv.data());
    ::_exit(127);
  }
  const int fork_errno = errno;
  ::close(fds[0]);
  if (log >= 0) ::close(log);
  if (pid_ < 0) {
    ::close(fds[1]);
    throw std::runtime_error("cannot start ffmpeg: " + std::string(std::strerror(fork_errno)));
  }
  registerChild(pid_);
  fd_ = fds[1];
  ::fcntl(fd_, F_SETFL, ::fcntl(fd_, F_GETFL) | O_NONBLOCK);
}

VideoWriter::~VideoWriter() {
  if (fd_ >= 0) ::close(fd_);
  if (pid_ > 0) {
    endProcess(pid_, 1.0);
    unregisterChild(pid_);
  }
}

int VideoWriter::remainingMs() const {
  const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
                        deadline_ - std::chrono::steady_clock::now())
                        .count();
  return left > 0 ? static_cast<int>(std::min<long long>(left, 1000000)) : 0;
}

void VideoWriter::add(const Image& frame) {
  if (failed_ || fd_ < 0) return;
  if (frame.width != width_ || frame.height != height_) {
    failed_ = true;
    return;
  }
  const unsigned char* data = frame.rgb.data();
  std::size_t left = frame.rgb.size();
  while (left > 0) {
    const ssize_t n = ::write(fd_, data, left);
    if (n > 0) {
      data += n;
      left -= static_cast<std::size_t>(n);
      continue;
    }
    if (n < 0 && errno == EINTR) {
      if (interruptRequested()) return;  // the caller ends the video
      continue;
    }
    if (n < 0 && errno == EAGAIN) {
      struct pollfd p {
        fd_, POLLOUT, 0
      };
      const int ready = ::poll(&p, 1, std::min(remainingMs(), 100));
      if (ready == 0 && remainingMs() == 0) {
        timed_out_ = true;
        failed_ = true;
        return;
      }
      if (interruptRequested()) return;
      continue;
    }
    failed_ = true;  // ffmpeg is gone (EPIPE)
    return;
  }
}

void VideoWriter::finish() {
  if (pid_ <= 0) return;
  ::close(fd_);
  fd_ = -1;
  int status = 0;
  pid_t r = 0;
  while (!timed_out_ && (r = ::waitpid(pid_, &status, WNOHANG)) == 0) {
    if (remainingMs() == 0) {
      timed_out_ = true;
      break;
    }
    if (interruptRequested()) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  const bool ended = r == pid_;  // by itself, not stopped
  if (!ended) status = endProcess(pid_, 1.0);
  unregisterChild(pid_);
  pid_ = -1;
  std::ifstream log(log_path_);
  std::stringstream messages;
  messages << log.rdbuf();
  std::remove(log_path_.c_str());
  if (failed_ || !ended || exitStatusOf(status) != 0) {
    std::remove(path_.c_str());
    throwIfInterrupted();
    if (timed_out_) {
      char limit[64];
      std::snprintf(limit, sizeof limit, "%.0f", time_limit_);
      throw std::runtime_error("ffmpeg did not finish '" + path_ + "' within " + limit +
                               " s and was stopped");
    }
    throw std::runtime_error("ffmpeg failed to write '" + path_ + "': " + messages.str());
  }
}

}  // namespace rollstep::experiments
