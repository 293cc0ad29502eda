#pragma once
// Common types of the ocp layer.
#include <Eigen/Core>

namespace rollstep::ocp {

using Eigen::MatrixXd;
using Eigen::VectorXd;
using VecRef = Eigen::Ref<VectorXd>;
using MatRef = Eigen::Ref<MatrixXd>;
using ConstVecRef = const Eigen::Ref<const VectorXd>&;
using ConstMatRef = const Eigen::Ref<const MatrixXd>&;

class ModeSchedule;

/// Problem-specific values shared by all terms of one node (for example the rigid-body
/// kinematics of a robot, computed once per node and read by every constraint).
/// Created per node by a NodePrecomputation; derived classes add their fields.
class NodeCache {
 public:
  virtual ~NodeCache() = default;
};

/// Where a node sits in the horizon. Passed to every term so that a term can depend on
/// time (references, swing trajectories) and on the mode (contact flags).
struct NodeContext {
  int node = 0;                            ///< 0..N-1 running nodes, N the terminal node
  bool terminal = false;                   ///< true for node N (no input, no dynamics)
  double time = 0.0;                       ///< time at the node [s]
  double dt = 0.0;                         ///< step to the next node [s]; 0 at the terminal node
  int mode = 0;                            ///< mode active at `time` (from the schedule)
  const ModeSchedule* schedule = nullptr;  ///< the whole schedule, for phase-dependent terms
  NodeCache* cache = nullptr;              ///< shared precomputation of this node (may be null)
};

/// Which nodes a term applies to.
enum class Stage : unsigned { Running = 1u, Terminal = 2u, All = 3u };
inline bool appliesTo(Stage s, bool terminal) {
  return (static_cast<unsigned>(s) & (terminal ? 2u : 1u)) != 0u;
}

}  // namespace rollstep::ocp
