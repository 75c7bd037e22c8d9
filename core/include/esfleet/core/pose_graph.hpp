#pragma once
// A 2D pose graph and its least-squares optimiser (ours, beyond the paper: the paper has no
// loop closure). Nodes are poses; an edge (i, j, z, information) says "node j seen from node i
// is z". Optimisation is Gauss-Newton on SE(2) with a sparse Cholesky solve (Eigen
// SimplicialLDLT); node 0 is held fixed. Edges may use a Huber kernel so that a loop closure
// that disagrees with the rest of the graph loses weight instead of bending it.

#include <cstddef>
#include <vector>

#include "esfleet/core/geometry.hpp"

namespace esfleet {

struct PoseGraphEdge {
  std::size_t from = 0;
  std::size_t to = 0;
  Pose2 measurement;               ///< pose of `to` in the frame of `from`
  double info_xy = 1.0 / 1e-4;     ///< information (1/sigma^2) of x and y, 1/m^2
  double info_theta = 1.0 / 1e-4;  ///< information of theta, 1/rad^2
  double huber = 0.0;  ///< Huber threshold on the whitened error norm; 0 = plain least squares
};

struct PoseGraphResult {
  int iterations = 0;
  double initial_cost = 0.0;  ///< sum of (robustified) squared whitened errors before
  double final_cost = 0.0;    ///< ... and after
  bool converged = false;
};

class PoseGraph {
 public:
  std::size_t add_node(const Pose2& pose);
  void add_edge(const PoseGraphEdge& edge);  ///< throws std::out_of_range on a bad node index

  std::size_t node_count() const { return nodes_.size(); }
  const std::vector<Pose2>& nodes() const { return nodes_; }
  const Pose2& node(std::size_t i) const { return nodes_[i]; }
  void set_node(std::size_t i, const Pose2& p) { nodes_[i] = p; }
  const std::vector<PoseGraphEdge>& edges() const { return edges_; }
  void pop_edge() { edges_.pop_back(); }
  void set_nodes(std::vector<Pose2> nodes) { nodes_ = std::move(nodes); }
  /// A graph of the first `nodes` nodes and `edges` edges of this one (an earlier state of a
  /// graph that only grew since). Throws std::out_of_range if it has fewer, or if a kept edge
  /// names a node left out.
  PoseGraph prefix(std::size_t nodes, std::size_t edges) const;

  /// Gauss-Newton until the update is below 1e-6 or `max_iterations`.
  PoseGraphResult optimize(int max_iterations = 10);

  /// Sum of the (robustified) whitened squared errors of all edges.
  double cost() const;
  /// Whitened squared error of one edge at the current node poses.
  double edge_chi2(const PoseGraphEdge& e) const;

 private:
  std::vector<Pose2> nodes_;
  std::vector<PoseGraphEdge> edges_;
};

}  // namespace esfleet
