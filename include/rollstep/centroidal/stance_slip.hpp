#pragma once
// The stance velocities the side-by-side rule frees, as a least-squares residual.
//
// When both feet of a side pair are in stance, the paper imposes the stance velocity
// equalities (z, drive-wheel lateral) on the first foot only: with both, the rows are not
// full rank in u (all six z rows and two lateral rows have rank 7 on Tachyon 3: the
// lateral rows reach the base roll rate only through the knees the z rows already use).
// Without anything in their place the optimum moves the freed foot freely: a stance wheel
// rose at 0.9 m/s in a trot on flat ground. This residual carries the freed rows
// (world z velocity, and lateral velocity in the foot's yaw frame for a drive wheel) into
// a cost, which needs no rank: the foot then stays put as far as the rest allows.
#include <memory>

#include "rollstep/centroidal/equalities.hpp"
#include "rollstep/centroidal/precomputation.hpp"
#include "rollstep/ocp/residual.hpp"

namespace rollstep::centroidal {

class FreedStanceVelocityResidual final : public ocp::Residual {
 public:
  explicit FreedStanceVelocityResidual(std::shared_ptr<const CentroidalPrecomputation> pre);
  int rows(const ocp::NodeContext& ctx) const override;
  std::unique_ptr<ocp::ResidualData> createData() const override;
  void calc(const ocp::NodeContext& ctx, ocp::ConstVecRef x, ocp::ConstVecRef u,
            ocp::ResidualData& d) const override;
  void calcDiff(const ocp::NodeContext& ctx, ocp::ConstVecRef x, ocp::ConstVecRef u,
                ocp::ResidualData& d) const override;

 private:
  /// In stance in `mode` but freed by the side-by-side rule.
  bool freed(int mode, int i) const;
  std::shared_ptr<const CentroidalPrecomputation> pre_;
};

}  // namespace rollstep::centroidal
