#include "esfleet/core/pose_graph.hpp"

#include <Eigen/Sparse>
#include <Eigen/SparseCholesky>
#include <cmath>
#include <stdexcept>

namespace esfleet {

std::size_t PoseGraph::add_node(const Pose2& pose) {
  nodes_.push_back(pose);
  return nodes_.size() - 1;
}

void PoseGraph::add_edge(const PoseGraphEdge& edge) {
  if (edge.from >= nodes_.size() || edge.to >= nodes_.size() || edge.from == edge.to) {
    throw std::out_of_range("pose graph edge " + std::to_string(edge.from) + " -> " +
                            std::to_string(edge.to) + " with " + std::to_string(nodes_.size()) +
                            " nodes");
  }
  edges_.push_back(edge);
}

namespace {

/// Error of an edge: t2v(z^-1 * (x_i^-1 * x_j)), with its Jacobians w.r.t. x_i and x_j.
struct Linearized {
  Eigen::Vector3d e;
  Eigen::Matrix3d a;  // d e / d x_i
  Eigen::Matrix3d b;  // d e / d x_j
};

Linearized linearize(const Pose2& xi, const Pose2& xj, const Pose2& z) {
  const double ci = std::cos(xi.theta), si = std::sin(xi.theta);
  const double cz = std::cos(z.theta), sz = std::sin(z.theta);
  const Eigen::Matrix2d ri_t{{ci, si}, {-si, ci}};
  const Eigen::Matrix2d rz_t{{cz, sz}, {-sz, cz}};
  const Eigen::Matrix2d dri_t{{-si, ci}, {-ci, -si}};  // d(R_i^T)/d theta_i
  const Eigen::Vector2d dt{xj.x - xi.x, xj.y - xi.y};
  Linearized l;
  l.e.head<2>() = rz_t * (ri_t * dt - Eigen::Vector2d{z.x, z.y});
  l.e(2) = normalize_angle(xj.theta - xi.theta - z.theta);
  l.a.setZero();
  l.a.topLeftCorner<2, 2>() = -rz_t * ri_t;
  l.a.block<2, 1>(0, 2) = rz_t * dri_t * dt;
  l.a(2, 2) = -1.0;
  l.b.setZero();
  l.b.topLeftCorner<2, 2>() = rz_t * ri_t;
  l.b(2, 2) = 1.0;
  return l;
}

double whitened_chi2(const Eigen::Vector3d& e, const PoseGraphEdge& edge) {
  return edge.info_xy * (e(0) * e(0) + e(1) * e(1)) + edge.info_theta * e(2) * e(2);
}

/// Huber: weight of an edge with squared whitened error chi2 (IRLS) and its robust cost.
double huber_weight(double chi2, double delta) {
  if (delta <= 0.0) return 1.0;
  const double r = std::sqrt(chi2);
  return r <= delta ? 1.0 : delta / r;
}
double huber_cost(double chi2, double delta) {
  if (delta <= 0.0) return chi2;
  const double r = std::sqrt(chi2);
  return r <= delta ? chi2 : 2.0 * delta * r - delta * delta;
}

}  // namespace

double PoseGraph::edge_chi2(const PoseGraphEdge& e) const {
  return whitened_chi2(linearize(nodes_[e.from], nodes_[e.to], e.measurement).e, e);
}

double PoseGraph::cost() const {
  double c = 0.0;
  for (const auto& e : edges_) c += huber_cost(edge_chi2(e), e.huber);
  return c;
}

PoseGraphResult PoseGraph::optimize(int max_iterations) {
  PoseGraphResult result;
  const std::size_t n = nodes_.size();
  result.initial_cost = cost();
  if (n < 2 || edges_.empty()) {
    result.final_cost = result.initial_cost;
    result.converged = true;
    return result;
  }
  const auto dim = static_cast<Eigen::Index>(3 * n);
  // Every iteration's system has the same sparsity pattern (one block per node and per edge):
  // the fill-reducing ordering and the symbolic factorisation are computed once.
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower> solver;
  for (int it = 0; it < max_iterations; ++it) {
    // The lower triangle only (what SimplicialLDLT reads): 21 entries per edge instead of 36.
    std::vector<Eigen::Triplet<double>> triplets;
    triplets.reserve(edges_.size() * 21 + 3);
    Eigen::VectorXd b = Eigen::VectorXd::Zero(dim);
    for (const auto& edge : edges_) {
      const Linearized l = linearize(nodes_[edge.from], nodes_[edge.to], edge.measurement);
      const double w = huber_weight(whitened_chi2(l.e, edge), edge.huber);
      const Eigen::Vector3d info{w * edge.info_xy, w * edge.info_xy, w * edge.info_theta};
      const Eigen::Matrix3d omega = info.asDiagonal();
      const Eigen::Matrix3d haa = l.a.transpose() * omega * l.a;
      const Eigen::Matrix3d hab = l.a.transpose() * omega * l.b;
      const Eigen::Matrix3d hbb = l.b.transpose() * omega * l.b;
      const auto i = static_cast<Eigen::Index>(3 * edge.from);
      const auto j = static_cast<Eigen::Index>(3 * edge.to);
      for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) {
          if (c <= r) {
            triplets.emplace_back(i + r, i + c, haa(r, c));
            triplets.emplace_back(j + r, j + c, hbb(r, c));
          }
          // The off-diagonal block: H(i, j) = hab, H(j, i) = hab^T; keep the one below.
          if (j > i) {
            triplets.emplace_back(j + r, i + c, hab(c, r));
          } else {
            triplets.emplace_back(i + r, j + c, hab(r, c));
          }
        }
      }
      b.segment<3>(i) += l.a.transpose() * omega * l.e;
      b.segment<3>(j) += l.b.transpose() * omega * l.e;
    }
    // Hold node 0 fixed with a stiff prior.
    for (int r = 0; r < 3; ++r) triplets.emplace_back(r, r, 1e12);
    Eigen::SparseMatrix<double> h(dim, dim);
    h.setFromTriplets(triplets.begin(), triplets.end());
    // The triplets go before the factorisation (the peak memory of a large final pass).
    triplets = {};
    if (it == 0) solver.analyzePattern(h);
    solver.factorize(h);
    if (solver.info() != Eigen::Success) break;
    const Eigen::VectorXd dx = solver.solve(-b);
    if (solver.info() != Eigen::Success || !dx.allFinite()) break;
    for (std::size_t k = 0; k < n; ++k) {
      const auto o = static_cast<Eigen::Index>(3 * k);
      nodes_[k].x += dx(o);
      nodes_[k].y += dx(o + 1);
      nodes_[k].theta = normalize_angle(nodes_[k].theta + dx(o + 2));
    }
    result.iterations = it + 1;
    if (dx.lpNorm<Eigen::Infinity>() < 1e-6) {
      result.converged = true;
      break;
    }
  }
  result.final_cost = cost();
  return result;
}

PoseGraph PoseGraph::prefix(std::size_t nodes, std::size_t edges) const {
  if (nodes > nodes_.size() || edges > edges_.size()) {
    throw std::out_of_range("pose graph prefix of " + std::to_string(nodes) + " nodes, " +
                            std::to_string(edges) + " edges: the graph has " +
                            std::to_string(nodes_.size()) + ", " + std::to_string(edges_.size()));
  }
  PoseGraph g;
  g.nodes_.assign(nodes_.begin(), nodes_.begin() + static_cast<std::ptrdiff_t>(nodes));
  g.edges_.reserve(edges);
  for (std::size_t i = 0; i < edges; ++i) g.add_edge(edges_[i]);
  return g;
}

}  // namespace esfleet
