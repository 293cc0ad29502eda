#pragma once
// Offscreen pictures of a run: MuJoCo renders the robot in its scene, posed from each log row
// (base pose and joint positions; the wheels' spin is not logged), into an OSMesa context
// (no display needed). PNGs through lodepng (MuJoCo's own dependency), videos through
// Debian's ffmpeg fed raw frames on a pipe. Without OSMesa at build time, or ffmpeg at run
// time, the functions say so (available() false with the reason), never crash.
#include <sys/types.h>

#include <chrono>
#include <memory>
#include <string>
#include <vector>

#include "log_table.hpp"
#include "rollstep/sim/plant.hpp"

namespace rollstep::experiments {

/// An RGB picture, rows top to bottom.
struct Image {
  int width = 0, height = 0;
  std::vector<unsigned char> rgb;
};

class Renderer {
 public:
  /// A renderer of `plant`'s scene (the model is copied). Throws std::runtime_error with the
  /// reason if offscreen rendering is not available (built without OSMesa, no context).
  /// `fast`: no shadows or reflections (videos: many frames on a software renderer).
  Renderer(const sim::Plant& plant, int width, int height, bool fast = false);
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  /// The robot posed as in `row` of a `rollstep sim` log, seen from its left-front with the
  /// camera following the base.
  /// `label` is written in the top left corner.
  Image render(const LogTable& log, std::size_t row, const std::string& label = "");

  /// False (with the reason) when this build cannot render offscreen.
  static bool available(std::string& reason);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Frames side by side in `columns` columns (all of the first frame's size).
Image tile(const std::vector<Image>& frames, int columns);
/// Writes a PNG; throws std::runtime_error naming the file on failure.
void writePng(const std::string& path, const Image& image);

/// An MP4 (H.264) written by ffmpeg from raw RGB frames on its standard input.
class VideoWriter {
 public:
  /// Starts ffmpeg; throws std::runtime_error if it is not on PATH or does not start. It
  /// gets this process's interrupts; all of it (every frame and the end) must take at most
  /// `time_limit` seconds.
  VideoWriter(const std::string& path, int width, int height, int fps, double time_limit = 600.0);
  /// Ends ffmpeg if it still runs (an exception left the video unfinished).
  ~VideoWriter();
  VideoWriter(const VideoWriter&) = delete;
  VideoWriter& operator=(const VideoWriter&) = delete;
  /// Writes a frame (returns at once after an interrupt; the caller ends the video).
  void add(const Image& frame);
  /// Closes the pipe and waits; throws std::runtime_error with ffmpeg's messages if it
  /// failed or ran past the time limit (then ended), Interrupted after an interrupt.
  void finish();

 private:
  int remainingMs() const;

  std::string path_, log_path_;
  int width_, height_;
  std::chrono::steady_clock::time_point deadline_;
  double time_limit_;
  pid_t pid_ = -1;
  int fd_ = -1;
  bool failed_ = false, timed_out_ = false;
};

}  // namespace rollstep::experiments
