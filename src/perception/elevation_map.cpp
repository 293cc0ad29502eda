#include "rollstep/perception/elevation_map.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "rollstep/common/number_text.hpp"

namespace rollstep::perception {

namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr double kPi = 3.14159265358979323846;

void require(bool ok, const char* name, double value, const char* what) {
  if (!ok) {
    throw std::invalid_argument(std::string("elevation map: ") + name + " = " +
                                shortestNumberText(value) + ": " + what);
  }
}

}  // namespace

void ElevationMapSettings::validate() const {
  require(std::isfinite(resolution) && resolution >= 0.005 && resolution <= 0.5, "resolution",
          resolution, "must be in [0.005, 0.5] m");
  require(std::isfinite(length) && length >= 4 * resolution && length / resolution <= 2000,
          "length", length, "must span 4 to 2000 cells");
  require(std::isfinite(sensor_noise) && sensor_noise > 0 && sensor_noise <= 1, "sensor_noise",
          sensor_noise, "must be in (0, 1] m");
  require(std::isfinite(range_noise_slope) && range_noise_slope >= 0 && range_noise_slope <= 1,
          "range_noise_slope", range_noise_slope, "must be in [0, 1]");
  require(std::isfinite(gate) && gate > 0, "gate", gate, "must be > 0");
  require(std::isfinite(process_noise) && process_noise >= 0, "process_noise", process_noise,
          "must be >= 0");
  require(std::isfinite(min_variance) && min_variance > 0, "min_variance", min_variance,
          "must be > 0");
  require(std::isfinite(max_variance) && max_variance > min_variance, "max_variance", max_variance,
          "must be > min_variance");
  require(visibility_stride >= 1 && visibility_stride <= 1000, "visibility_stride",
          visibility_stride, "must be 1 to 1000");
  require(std::isfinite(visibility_margin) && visibility_margin >= 0, "visibility_margin",
          visibility_margin, "must be >= 0");
  require(std::isfinite(min_range) && min_range >= 0, "min_range", min_range, "must be >= 0");
  require(std::isfinite(max_range) && max_range > min_range, "max_range", max_range,
          "must be > min_range");
}

ElevationMap::ElevationMap(const ElevationMapSettings& settings) : settings_(settings) {
  settings_.validate();
  res_ = settings_.resolution;
  n_ = std::max(4, static_cast<int>(std::lround(settings_.length / res_)));
  const auto cells = static_cast<std::size_t>(n_) * static_cast<std::size_t>(n_);
  height_.assign(cells, kNaN);
  variance_.assign(cells, kNaN);
  scratch_h_.assign(cells, kNaN);
  scratch_v_.assign(cells, kNaN);
  gx0_ = gy0_ = -n_ / 2;
}

bool ElevationMap::cellOf(const Eigen::Vector2d& p, int& r, int& c) const {
  if (!p.allFinite()) return false;
  const double fx = std::floor(p.x() / res_) - static_cast<double>(gx0_);
  const double fy = std::floor(p.y() / res_) - static_cast<double>(gy0_);
  if (fx < 0 || fy < 0 || fx >= n_ || fy >= n_) return false;
  c = static_cast<int>(fx);
  r = static_cast<int>(fy);
  return true;
}

bool ElevationMap::moveTo(const Eigen::Vector2d& center) {
  if (!center.allFinite() || center.cwiseAbs().maxCoeff() > 1e6) return false;
  const long nx = static_cast<long>(std::floor(center.x() / res_)) - n_ / 2;
  const long ny = static_cast<long>(std::floor(center.y() / res_)) - n_ / 2;
  const long dx = nx - gx0_, dy = ny - gy0_;
  if (dx == 0 && dy == 0) return true;
  for (int r = 0; r < n_; ++r) {
    for (int c = 0; c < n_; ++c) {
      const long orow = r + dy, ocol = c + dx;
      const auto i = static_cast<std::size_t>(r * n_ + c);
      if (orow >= 0 && orow < n_ && ocol >= 0 && ocol < n_) {
        const auto o = static_cast<std::size_t>(orow * n_ + ocol);
        scratch_h_[i] = height_[o];
        scratch_v_[i] = variance_[o];
      } else {
        scratch_h_[i] = scratch_v_[i] = kNaN;
      }
    }
  }
  height_.swap(scratch_h_);
  variance_.swap(scratch_v_);
  gx0_ = nx;
  gy0_ = ny;
  return true;
}

void ElevationMap::predict(double dt) {
  if (!(dt > 0) || !std::isfinite(dt)) return;
  const auto grow = static_cast<float>(settings_.process_noise * dt);
  const auto vmax = static_cast<float>(settings_.max_variance);
  for (std::size_t i = 0; i < height_.size(); ++i) {
    if (std::isnan(height_[i])) continue;
    variance_[i] += grow;
    if (variance_[i] > vmax) height_[i] = variance_[i] = kNaN;
  }
}

void ElevationMap::fuse(std::size_t i, double z, double var) {
  float& h = height_[i];
  float& v = variance_[i];
  if (std::isnan(h)) {
    h = static_cast<float>(z);
    v = static_cast<float>(var);
    return;
  }
  const double hd = static_cast<double>(h), vd = static_cast<double>(v);
  const double d = z - hd;
  const double s = vd + var;
  if (d * d > settings_.gate * settings_.gate * s) {
    if (d > 0) {
      h = static_cast<float>(z);
      v = static_cast<float>(var);
    } else {
      v = static_cast<float>(std::min(settings_.max_variance, vd + var));
    }
    return;
  }
  h = static_cast<float>((var * hd + vd * z) / s);
  v = static_cast<float>(std::max(settings_.min_variance, vd * var / s));
}

int ElevationMap::clearAlongRay(const Eigen::Vector3d& from, const Eigen::Vector3d& to,
                                double top) {
  const Eigen::Vector3d d = to - from;
  const double horizontal = d.head<2>().norm();
  // Only where the ray runs below the map's highest cell (less the margin) can it clear
  // anything: start there.
  double t0 = 0.0;
  const double z_clear = top - settings_.visibility_margin;
  if (from.z() >= z_clear) {
    if (to.z() >= z_clear) return 0;
    t0 = (from.z() - z_clear) / (from.z() - to.z());
  }
  // One sample per cell length; the last two cells before the hit are left alone (the ray
  // may graze the surface there). Positions in cells, advanced incrementally.
  const int steps = static_cast<int>(horizontal / res_) - 2;
  if (steps < 2) return 0;
  const double dt = res_ / horizontal;
  const double sx = d.x() * dt / res_, sy = d.y() * dt / res_, sz = d.z() * dt;
  const int k0 = std::max(1, static_cast<int>(t0 / dt));
  double fx = from.x() / res_ - static_cast<double>(gx0_) + (k0 - 1) * sx;
  double fy = from.y() / res_ - static_cast<double>(gy0_) + (k0 - 1) * sy;
  double z = from.z() + settings_.visibility_margin + (k0 - 1) * sz;
  int cleared = 0;
  for (int k = k0; k < steps; ++k) {
    fx += sx;
    fy += sy;
    z += sz;
    if (fx < 0 || fy < 0 || fx >= n_ || fy >= n_) continue;
    const auto i = static_cast<std::size_t>(static_cast<int>(fy) * n_ + static_cast<int>(fx));
    // NaN compares false: empty cells are skipped.
    if (static_cast<double>(height_[i]) > z) {
      height_[i] = variance_[i] = kNaN;
      ++cleared;
    }
  }
  return cleared;
}

MapUpdateStats ElevationMap::update(const Eigen::Vector3d* points, int count,
                                    const Eigen::Isometry3d& sensor_pose) {
  MapUpdateStats stats;
  stats.points = std::max(0, count);
  if (!sensor_pose.matrix().allFinite()) {
    stats.non_finite = stats.points;
    return stats;
  }
  const Eigen::Vector3d origin = sensor_pose.translation();
  // The highest cell, kept up to date as points are fused (bounds the visibility walk).
  double top = -std::numeric_limits<double>::infinity();
  if (settings_.visibility_cleanup) {
    for (const float h : height_) {
      if (static_cast<double>(h) > top) top = static_cast<double>(h);  // NaN compares false
    }
  }
  for (int k = 0; k < count; ++k) {
    const Eigen::Vector3d& ps = points[k];
    if (!ps.allFinite()) {
      ++stats.non_finite;
      continue;
    }
    const double range = ps.norm();
    int r = 0, c = 0;
    const Eigen::Vector3d p = sensor_pose * ps;
    if (range < settings_.min_range || range > settings_.max_range || !cellOf(p.head<2>(), r, c)) {
      ++stats.out_of_map;
      continue;
    }
    if (settings_.visibility_cleanup && k % settings_.visibility_stride == 0) {
      stats.cleared += clearAlongRay(origin, p, top);
    }
    top = std::max(top, p.z());
    const double sigma = settings_.sensor_noise + settings_.range_noise_slope * range;
    fuse(static_cast<std::size_t>(r * n_ + c), p.z(), sigma * sigma);
    ++stats.fused;
  }
  return stats;
}

namespace {

// The plane through contact points: z = mean.z + g . (p - mean.xy), g by least squares when
// they span an area (level through their mean height otherwise). False for no or
// non-finite contacts.
bool contactPlane(const Eigen::Vector3d* contacts, int count, Eigen::Vector3d& mean,
                  Eigen::Vector2d& g) {
  if (count <= 0) return false;
  mean.setZero();
  for (int k = 0; k < count; ++k) {
    if (!contacts[k].allFinite()) return false;
    mean += contacts[k];
  }
  mean /= count;
  Eigen::Matrix2d C = Eigen::Matrix2d::Zero();
  Eigen::Vector2d rhs = Eigen::Vector2d::Zero();
  for (int k = 0; k < count; ++k) {
    const Eigen::Vector2d d = contacts[k].head<2>() - mean.head<2>();
    C += d * d.transpose();
    rhs += d * (contacts[k].z() - mean.z());
  }
  g.setZero();
  if (count >= 3 && C.determinant() > 1e-8) g = C.ldlt().solve(rhs);
  return true;
}

}  // namespace

int ElevationMap::fillFootprint(const Eigen::Vector3d* contacts, int count, double margin,
                                double variance) {
  Eigen::Vector3d mean;
  Eigen::Vector2d g;
  if (!std::isfinite(margin) || margin < 0 || !std::isfinite(variance) || variance <= 0 ||
      !contactPlane(contacts, count, mean, g)) {
    return 0;
  }
  Eigen::Vector2d lo = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector2d hi = -lo;
  for (int k = 0; k < count; ++k) {
    lo = lo.cwiseMin(contacts[k].head<2>());
    hi = hi.cwiseMax(contacts[k].head<2>());
  }
  lo.array() -= margin;
  hi.array() += margin;
  int filled = 0;
  for (int r = 0; r < n_; ++r) {
    for (int c = 0; c < n_; ++c) {
      const Eigen::Vector2d p = cellCenter(r, c);
      if ((p.array() < lo.array()).any() || (p.array() > hi.array()).any()) continue;
      const auto i = static_cast<std::size_t>(r * n_ + c);
      if (!std::isnan(height_[i])) continue;
      height_[i] = static_cast<float>(mean.z() + g.dot(p - mean.head<2>()));
      variance_[i] = static_cast<float>(variance);
      ++filled;
    }
  }
  return filled;
}

int ElevationMap::fillBlindZone(const Eigen::Vector2d& sensor_xy, const Eigen::Vector3d* contacts,
                                int count, double max_radius, double max_step, double variance) {
  Eigen::Vector3d mean;
  Eigen::Vector2d g;
  if (!sensor_xy.allFinite() || !std::isfinite(max_radius) || max_radius <= 0 ||
      !std::isfinite(max_step) || max_step < 0 || !std::isfinite(variance) || variance <= 0 ||
      !contactPlane(contacts, count, mean, g)) {
    return 0;
  }
  const auto plane = [&](const Eigen::Vector2d& p) { return mean.z() + g.dot(p - mean.head<2>()); };
  // Azimuth sectors of kBlindZoneSectors around the sensor; per sector the nearest measured
  // cell, and whether it continues the contact plane.
  std::array<double, kBlindZoneSectors> nearest;
  std::array<bool, kBlindZoneSectors> level;
  nearest.fill(std::numeric_limits<double>::infinity());
  level.fill(false);
  const double per_radian = kBlindZoneSectors / (2 * kPi);
  const auto sectorOf = [&](const Eigen::Vector2d& d) {
    const int s = static_cast<int>(std::floor((std::atan2(d.y(), d.x()) + kPi) * per_radian));
    return std::clamp(s, 0, kBlindZoneSectors - 1);
  };
  for (int r = 0; r < n_; ++r) {
    for (int c = 0; c < n_; ++c) {
      const float h = height_[static_cast<std::size_t>(r * n_ + c)];
      if (std::isnan(h)) continue;
      const Eigen::Vector2d p = cellCenter(r, c);
      const Eigen::Vector2d d = p - sensor_xy;
      const double dist = d.norm();
      if (dist > max_radius) continue;
      const auto s = static_cast<std::size_t>(sectorOf(d));
      if (dist < nearest[s]) {
        nearest[s] = dist;
        level[s] = std::abs(static_cast<double>(h) - plane(p)) <= max_step;
      }
    }
  }
  // A sector is narrower than a cell beyond about 2 m, and near a diagonal of the grid the
  // cells' centres leave some sectors empty even nearer: each sector is bounded by the
  // nearest measured cell over kBlindZoneWindow sectors on either side, and filled only if
  // every measured one of them is level.
  std::array<double, kBlindZoneSectors> bound;
  for (int k = 0; k < kBlindZoneSectors; ++k) {
    double b = std::numeric_limits<double>::infinity();
    bool ok = true;
    for (int j = k - kBlindZoneWindow; j <= k + kBlindZoneWindow; ++j) {
      const auto n = static_cast<std::size_t>((j + kBlindZoneSectors) % kBlindZoneSectors);
      if (!std::isfinite(nearest[n])) continue;
      b = std::min(b, nearest[n]);
      ok = ok && level[n];
    }
    bound[static_cast<std::size_t>(k)] =
        ok && std::isfinite(b) ? b : 0.0;  // none seen: none filled
  }
  int filled = 0;
  for (int r = 0; r < n_; ++r) {
    for (int c = 0; c < n_; ++c) {
      const auto i = static_cast<std::size_t>(r * n_ + c);
      if (!std::isnan(height_[i])) continue;
      const Eigen::Vector2d p = cellCenter(r, c);
      const Eigen::Vector2d d = p - sensor_xy;
      if (d.norm() >= bound[static_cast<std::size_t>(sectorOf(d))]) continue;
      height_[i] = static_cast<float>(plane(p));
      variance_[i] = static_cast<float>(variance);
      ++filled;
    }
  }
  return filled;
}

void ElevationMap::clear() {
  std::fill(height_.begin(), height_.end(), kNaN);
  std::fill(variance_.begin(), variance_.end(), kNaN);
}

int ElevationMap::validCells() const {
  return static_cast<int>(
      std::count_if(height_.begin(), height_.end(), [](float h) { return !std::isnan(h); }));
}

void ElevationMap::setCell(int r, int c, float height, float variance) {
  if (r < 0 || c < 0 || r >= n_ || c >= n_) return;
  const auto i = static_cast<std::size_t>(r * n_ + c);
  const bool ok = std::isfinite(height) && std::isfinite(variance) && variance > 0;
  height_[i] = ok ? height : kNaN;
  variance_[i] = ok ? variance : kNaN;
}

bool ElevationMap::copyFrom(const ElevationMap& other) {
  if (other.n_ != n_) return false;
  res_ = other.res_;
  gx0_ = other.gx0_;
  gy0_ = other.gy0_;
  std::copy(other.height_.begin(), other.height_.end(), height_.begin());
  std::copy(other.variance_.begin(), other.variance_.end(), variance_.begin());
  return true;
}

int ElevationMap::fillGaps(int max_gap_cells, double max_step, int max_shadow_cells) {
  if (max_shadow_cells < 0) max_shadow_cells = max_gap_cells;
  if ((max_gap_cells < 1 && max_shadow_cells < 1) || !(max_step >= 0.0)) return 0;
  const int reach = std::max(max_gap_cells, max_shadow_cells);
  // Decided on the map as it is (scratch copies), written back at the end.
  std::copy(height_.begin(), height_.end(), scratch_h_.begin());
  std::copy(variance_.begin(), variance_.end(), scratch_v_.begin());
  constexpr int kDirections[4][2] = {{0, 1}, {1, 0}, {1, 1}, {1, -1}};
  int filled = 0;
  for (int r = 0; r < n_; ++r) {
    for (int c = 0; c < n_; ++c) {
      const auto i = static_cast<std::size_t>(r * n_ + c);
      if (!std::isnan(height_[i])) continue;
      int best_gap = reach + 1;
      float best_h = kNaN, best_v = kNaN;
      for (const auto& d : kDirections) {
        // The nearest measured cell each way, at most `reach` steps (a gap of at most reach
        // empty cells has both ends within that many steps of any of its cells).
        int steps[2] = {0, 0};
        std::size_t end[2] = {0, 0};
        bool found[2] = {false, false};
        for (int side = 0; side < 2; ++side) {
          if (side == 1 && !found[0]) break;  // one side unseen: never extrapolated
          const int sign = side == 0 ? 1 : -1;
          for (int k = 1; k <= reach; ++k) {
            const int rr = r + sign * k * d[0], cc = c + sign * k * d[1];
            if (rr < 0 || cc < 0 || rr >= n_ || cc >= n_) break;
            const auto j = static_cast<std::size_t>(rr * n_ + cc);
            if (!std::isnan(height_[j])) {
              steps[side] = k;
              end[side] = j;
              found[side] = true;
              break;
            }
          }
        }
        if (!found[0] || !found[1]) continue;
        const int gap = steps[0] + steps[1] - 1;  // empty cells between the two ends
        if (gap >= best_gap) continue;
        const double h0 = static_cast<double>(height_[end[0]]);
        const double h1 = static_cast<double>(height_[end[1]]);
        if (gap > (std::abs(h0 - h1) <= max_step ? max_gap_cells : max_shadow_cells)) continue;
        const double w = static_cast<double>(steps[1]) / (steps[0] + steps[1]);
        best_gap = gap;
        // Across a step: the lower side (the shadow behind an edge is the lower surface
        // going on under it; anything higher there would have been seen).
        best_h = static_cast<float>(std::abs(h0 - h1) <= max_step ? w * h0 + (1.0 - w) * h1
                                                                  : std::min(h0, h1));
        best_v = std::max(variance_[end[0]], variance_[end[1]]);
      }
      if (best_gap <= reach) {
        scratch_h_[i] = best_h;
        scratch_v_[i] = best_v;
        ++filled;
      }
    }
  }
  std::copy(scratch_h_.begin(), scratch_h_.end(), height_.begin());
  std::copy(scratch_v_.begin(), scratch_v_.end(), variance_.begin());
  return filled;
}

}  // namespace rollstep::perception
