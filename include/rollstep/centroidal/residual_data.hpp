#pragma once
// The workspace the centroidal OCP's residuals share (equalities and costs): a fallback
// cache for calls without a node cache.
#include <memory>

#include "rollstep/centroidal/precomputation.hpp"
#include "rollstep/ocp/residual.hpp"

namespace rollstep::centroidal {

/// Workspace of the centroidal residuals: a fallback cache for calls without a node cache
/// (none when made for nodes that always have one, makeFallbackCache).
struct CentroidalResidualData : ocp::ResidualData {
  CentroidalResidualData(const CentroidalRobot& robot, int max_rows, bool node_cache)
      : ocp::ResidualData(max_rows, robot.ndx(), robot.nu()),
        fallback(makeFallbackCache(robot, node_cache)) {}
  std::unique_ptr<CentroidalCache> fallback;
};

}  // namespace rollstep::centroidal
