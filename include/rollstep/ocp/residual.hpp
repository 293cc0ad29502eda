#pragma once
// A vector function r(x, u) of one node with its Jacobians: the building block of
// least-squares costs, equality constraints (r = 0) and inequality constraints (r >= 0).
#include <memory>
#include <string>

#include "rollstep/ocp/types.hpp"

namespace rollstep::ocp {

/// Workspace of one residual at one node. Derived residuals may extend it.
struct ResidualData {
  ResidualData(int max_rows, int ndx, int nu)
      : r(VectorXd::Zero(max_rows)),
        Rx(MatrixXd::Zero(max_rows, ndx)),
        Ru(MatrixXd::Zero(max_rows, nu)) {}
  virtual ~ResidualData() = default;
  int rows = 0;  ///< rows active at this node, set by the caller from Residual::rows
  VectorXd r;    ///< value; rows [0, rows) are meaningful
  MatrixXd Rx;   ///< d r / d x in the tangent space of x (rows x ndx)
  MatrixXd Ru;   ///< d r / d u (rows x nu)
};

/// Columns [first, first + count) of a Jacobian.
struct ColumnRange {
  int first = 0;
  int count = 0;
};

class Residual {
 public:
  /// @param ndx tangent size of the state, @param nu input size,
  /// @param max_rows the largest number of rows this residual can have at any node.
  Residual(int ndx, int nu, int max_rows) : ndx_(ndx), nu_(nu), max_rows_(max_rows) {}
  virtual ~Residual() = default;

  int ndx() const { return ndx_; }
  int nu() const { return nu_; }
  int maxRows() const { return max_rows_; }

  /// Rows active at this node, in [0, maxRows()]. 0 means the term is inactive here
  /// (for example a stance-only constraint at a swing node). Must not allocate.
  virtual int rows(const NodeContext& /*ctx*/) const { return max_rows_; }
  /// False when the residual depends on the state only (Ru == 0): required for terminal
  /// terms and for soft (relaxed-barrier) inequalities.
  virtual bool dependsOnInput() const { return true; }
  /// False when the residual depends on the input only (Rx == 0), e.g. input tracking.
  virtual bool dependsOnState() const { return true; }
  /// The columns of Rx (tangent of x) and of Ru in which this residual's rows can be
  /// non-zero, at any node and in any mode: a structural pattern (every entry outside it is
  /// zero whatever x, u and the context). The solver sizes the storage it keeps of the
  /// inequality Jacobians from it. Declaring too few columns is an error the solver reports
  /// (std::logic_error) when it meets a non-zero there. Defaults: every column, none for
  /// the x side when !dependsOnState(), none for the u side when !dependsOnInput().
  virtual ColumnRange stateColumns() const { return {0, dependsOnState() ? ndx_ : 0}; }
  virtual ColumnRange inputColumns() const { return {0, dependsOnInput() ? nu_ : 0}; }
  /// True when the residual is affine in the tangent coordinates everywhere:
  /// r(x (+) dx, u + du) = r(x, u) + Rx dx + Ru du for every x, u, dx, du. Its second
  /// derivatives are then zero and the solver computes no curvature for it (a cost on it
  /// is exactly quadratic, a constraint on it adds nothing to the Lagrangian's Hessian).
  /// Declaring a nonlinear residual linear silently drops curvature: when unsure, keep
  /// the default.
  virtual bool isLinear() const { return false; }
  /// m > 0 when the first 2 m rows at this node are m two-sided limits lo <= h <= hi:
  /// row j and row j + m (j < m) are h_j - lo_j and hi_j - h_j, in either order, so that
  /// their Jacobians are exact negatives (Rx, Ru of row j + m = -those of row j, bit for
  /// bit). The solver then condenses each pair with one product and the summed barrier
  /// weight. 2 m <= rows(ctx); 0 (default) declares nothing. Must not allocate.
  virtual int mirroredRows(const NodeContext& /*ctx*/) const { return 0; }
  /// What row `row` (< rows(ctx)) of this node constrains, for diagnostics (constraint
  /// violation reports): "row 3" unless the residual says more ("LF_contact: edge 2 of
  /// region 5"). Allocates: never on a real-time path.
  virtual std::string rowName(const NodeContext& /*ctx*/, int row) const {
    return "row " + std::to_string(row);
  }

  /// Workspace of this residual at one node, for calls with or without a node cache.
  virtual std::unique_ptr<ResidualData> createData() const {
    return std::make_unique<ResidualData>(max_rows_, ndx_, nu_);
  }
  /// Workspace for a node whose every call carries the problem's node cache
  /// (NodeContext::cache set; OptimalControlProblem::createNodeData uses this when the
  /// problem has a NodePrecomputation). A residual that keeps a cache of its own for calls
  /// without one may leave it out (tens of kB per term and node for a robot's kinematics);
  /// such a workspace then refuses calls without ctx.cache. Default: createData().
  virtual std::unique_ptr<ResidualData> createDataWithNodeCache() const { return createData(); }
  /// Writes d.r.head(d.rows). At terminal nodes u is a zero vector of size nu.
  virtual void calc(const NodeContext& ctx, ConstVecRef x, ConstVecRef u,
                    ResidualData& d) const = 0;
  /// Writes d.Rx and d.Ru (top d.rows rows). Called right after calc with the same
  /// arguments, so it may reuse what calc stored in d.
  virtual void calcDiff(const NodeContext& ctx, ConstVecRef x, ConstVecRef u,
                        ResidualData& d) const = 0;
  /// Same Jacobians, written into Rx (rows(ctx) x ndx) and Ru (rows(ctx) x nu) instead of
  /// d.Rx, d.Ru: the problem passes the blocks of its stacked constraint matrices, so that
  /// a residual that overrides this writes its rows once instead of into d and then again
  /// by a copy. An override must write every entry of Rx and Ru (they hold other nodes'
  /// values). Default: calcDiff, then the copy. Called right after calc, like calcDiff.
  virtual void calcDiffInto(const NodeContext& ctx, ConstVecRef x, ConstVecRef u, ResidualData& d,
                            MatRef Rx, MatRef Ru) const {
    calcDiff(ctx, x, u, d);
    Rx = d.Rx.topRows(Rx.rows());
    Ru = d.Ru.topRows(Ru.rows());
  }

 private:
  int ndx_, nu_, max_rows_;
};

}  // namespace rollstep::ocp
