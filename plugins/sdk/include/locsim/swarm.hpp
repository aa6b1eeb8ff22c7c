// Swarm moves for particle filters (paper 001, SPEC section 3): the artificial fish swarm
// (prey, swarm, follow) and particle swarm optimisation move particle poses uphill on a fitness
// before resampling; directed resampling refills the worst half from the best particle seen
// (the bulletin board). Generic over the fitness: fitness(i, pose) is particle i's food
// concentration at `pose` (each FastSLAM particle scores a pose against its own map).
//
// Poses are (x [m], y [m], theta [rad]); distances between them are Euclidean with the heading
// scaled by heading_scale_m (metres per radian), the heading difference wrapped.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <numeric>
#include <vector>

#include "locsim/models.hpp"
#include "locsim/random.hpp"

namespace locsim::sdk {

/// The scaled difference b - a and its norm.
inline Eigen::Vector3d pose_difference(const Pose& a, const Pose& b, double heading_scale_m) {
  return {b(0) - a(0), b(1) - a(1), heading_scale_m * wrap(b(2) - a(2))};
}

/// `from` moved toward `to` by rand() * step along the scaled direction (not past `to`).
inline Pose step_toward(const Pose& from, const Pose& to, double step, double heading_scale_m,
                        Random& random) {
  const Eigen::Vector3d d = pose_difference(from, to, heading_scale_m);
  const double norm = d.norm();
  if (norm < 1e-12) return from;
  const double length = std::min(random.uniform() * step, norm);
  const Eigen::Vector3d move = d * (length / norm);
  return {from(0) + move(0), from(1) + move(1), wrap(from(2) + move(2) / heading_scale_m)};
}

/// A uniform point of the visual field: each scaled coordinate within +-visual.
inline Pose random_in_view(const Pose& at, double visual, double heading_scale_m, Random& random) {
  return {at(0) + random.uniform(-visual, visual), at(1) + random.uniform(-visual, visual),
          wrap(at(2) + random.uniform(-visual, visual) / heading_scale_m)};
}

struct AfsaDef {
  double visual = 0.05;          // Visual: how far a fish sees (scaled) [m]
  double step = 0.02;            // Step: the longest move (scaled) [m]
  double crowding = 0.6;         // delta: neighbours' mean food must exceed delta x own [-]
  int iterations = 3;            // rounds of prey / swarm / follow for every fish [-]
  int prey_tries = 3;            // points of the visual field tried before a random step [-]
  double heading_scale_m = 1.0;  // metres per radian in the distances [m/rad]
};

/// The artificial fish swarm: each round every fish tries prey, swarm and follow (as SPEC
/// section 3) and keeps whichever ends at the highest food concentration, if that is not below
/// its own (the paper moves anyway). Returns the number of fitness evaluations. Fish move one
/// after the other, each seeing the others' latest poses.
template <class Fitness>
long afsa_move(std::vector<Pose>& fish, Fitness&& fitness, const AfsaDef& def, Random& random) {
  const std::size_t n = fish.size();
  long evaluations = 0;
  const auto food = [&](std::size_t i, const Pose& p) {
    ++evaluations;
    return fitness(i, p);
  };
  std::vector<double> y(n);
  for (std::size_t i = 0; i < n; ++i) y[i] = food(i, fish[i]);
  const auto prey = [&](std::size_t i) {
    for (int t = 0; t < def.prey_tries; ++t) {
      const Pose target = random_in_view(fish[i], def.visual, def.heading_scale_m, random);
      if (food(i, target) > y[i])
        return step_toward(fish[i], target, def.step, def.heading_scale_m, random);
    }
    return random_in_view(fish[i], def.step, def.heading_scale_m, random);  // a random step
  };
  std::vector<std::size_t> neighbours;
  for (int round = 0; round < def.iterations; ++round) {
    for (std::size_t i = 0; i < n; ++i) {
      neighbours.clear();
      for (std::size_t j = 0; j < n; ++j) {
        if (j != i && pose_difference(fish[i], fish[j], def.heading_scale_m).norm() < def.visual)
          neighbours.push_back(j);
      }
      const auto nf = static_cast<double>(neighbours.size());
      // Prey.
      Pose best = prey(i);
      double best_y = food(i, best);
      const auto consider = [&](const Pose& candidate) {
        const double yc = food(i, candidate);
        if (yc > best_y) best = candidate, best_y = yc;
      };
      if (!neighbours.empty()) {
        // Swarm: toward the neighbours' centre if it is rich and not crowded.
        Eigen::Vector3d sum = Eigen::Vector3d::Zero();
        for (const std::size_t j : neighbours)
          sum += pose_difference(fish[i], fish[j], def.heading_scale_m);
        const Eigen::Vector3d mean = sum / nf;
        const Pose centre(fish[i](0) + mean(0), fish[i](1) + mean(1),
                          wrap(fish[i](2) + mean(2) / def.heading_scale_m));
        const double yc = food(i, centre);
        consider(yc / nf > def.crowding * y[i]
                     ? step_toward(fish[i], centre, def.step, def.heading_scale_m, random)
                     : prey(i));
        // Follow: toward the richest neighbour on the same condition.
        std::size_t richest = neighbours.front();
        for (const std::size_t j : neighbours)
          if (y[j] > y[richest]) richest = j;
        consider(y[richest] / nf > def.crowding * y[i]
                     ? step_toward(fish[i], fish[richest], def.step, def.heading_scale_m, random)
                     : prey(i));
      }
      // A fish keeps its place unless a behaviour raises its food: in a particle filter
      // a move downhill is a move away from the measurements, not exploration.
      if (best_y > y[i]) fish[i] = best, y[i] = best_y;
    }
  }
  return evaluations;
}

struct PsoDef {
  double inertia = 0.7;          // w: share of the last velocity kept [-]
  double cognitive = 1.5;        // c1: pull toward the particle's own best [-]
  double social = 1.5;           // c2: pull toward the swarm's best [-]
  int iterations = 3;            // [-]
  double max_speed = 0.1;        // longest move per iteration (scaled) [m]
  double heading_scale_m = 1.0;  // [m/rad]
};

/// Particle swarm optimisation from the current poses (velocities zero): each iteration
///   v <- w v + c1 r1 (p_best - x) + c2 r2 (g_best - x),  x <- x + v,
/// r1, r2 uniform per coordinate; poses end at each particle's own best (never below where it
/// started). Returns the number of fitness evaluations.
template <class Fitness>
long pso_move(std::vector<Pose>& poses, Fitness&& fitness, const PsoDef& def, Random& random) {
  const std::size_t n = poses.size();
  if (n == 0) return 0;
  std::vector<Pose> best = poses;
  std::vector<double> best_y(n);
  std::vector<Eigen::Vector3d> velocity(n, Eigen::Vector3d::Zero());
  long evaluations = 0;
  for (std::size_t i = 0; i < n; ++i) best_y[i] = fitness(i, poses[i]), ++evaluations;
  // The swarm's best is scored by each particle's own fitness: compare pose quality through
  // the best particle's score, the only one that is comparable across maps.
  std::size_t leader =
      static_cast<std::size_t>(std::max_element(best_y.begin(), best_y.end()) - best_y.begin());
  for (int it = 0; it < def.iterations; ++it) {
    for (std::size_t i = 0; i < n; ++i) {
      const Eigen::Vector3d to_own = pose_difference(poses[i], best[i], def.heading_scale_m);
      const Eigen::Vector3d to_leader =
          pose_difference(poses[i], best[leader], def.heading_scale_m);
      for (int k = 0; k < 3; ++k) {
        // One draw per statement: the operands of + are unsequenced and compilers differ (this
        // is the order gcc drew them in, which the results so far have).
        const double own_pull = random.uniform();
        const double leader_pull = random.uniform();
        velocity[i](k) = def.inertia * velocity[i](k) + def.cognitive * own_pull * to_own(k) +
                         def.social * leader_pull * to_leader(k);
      }
      const double speed = velocity[i].norm();
      if (speed > def.max_speed) velocity[i] *= def.max_speed / speed;
      poses[i] = {poses[i](0) + velocity[i](0), poses[i](1) + velocity[i](1),
                  wrap(poses[i](2) + velocity[i](2) / def.heading_scale_m)};
      const double y = fitness(i, poses[i]);
      ++evaluations;
      if (y > best_y[i]) best_y[i] = y, best[i] = poses[i];
    }
    leader =
        static_cast<std::size_t>(std::max_element(best_y.begin(), best_y.end()) - best_y.begin());
  }
  poses = best;
  return evaluations;
}

/// Directed resampling's draws (paper 001): the heavier half of the particles resampled by
/// weight (low variance), n - n/2 indices into `chosen`; the caller fills the other n/2 slots
/// from the bulletin board (ParticleFilter::keep, then the board's copies; or directed_resample).
inline void directed_resample_indices(const std::vector<double>& weights, Random& random,
                                      std::vector<std::size_t>& chosen) {
  const std::size_t n = weights.size();
  chosen.clear();
  if (n == 0) return;
  std::vector<std::size_t> order(n);
  std::iota(order.begin(), order.end(), std::size_t{0});
  // Heaviest first; ties by index, so the outcome does not depend on the sort.
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return weights[a] > weights[b] || (weights[a] == weights[b] && a < b);
  });
  const std::size_t kept = n - n / 2;
  double heavy = 0.0;
  for (std::size_t k = 0; k < kept; ++k) heavy += weights[order[k]];
  chosen.reserve(kept);
  const double spacing = heavy / static_cast<double>(kept);
  double pointer = random.uniform() * spacing, cumulative = weights[order[0]];
  std::size_t k = 0;
  for (std::size_t draw = 0; draw < kept; ++draw, pointer += spacing) {
    while (cumulative < pointer && k + 1 < kept) cumulative += weights[order[++k]];
    chosen.push_back(order[k]);
  }
}

/// Directed resampling (paper 001) of a vector of particles: the lighter half is dropped and
/// replaced by the board particle itself once and by from_board(random) for the rest (the board
/// predicted to now, plus noise); the heavier half is resampled by weight (low variance) into
/// the other slots. The count stays; weights become uniform. `Particle` is copyable.
template <class Particle, class FromBoard>
void directed_resample(std::vector<Particle>& particles, std::vector<double>& weights,
                       const Particle& board, FromBoard&& from_board, Random& random) {
  const std::size_t n = particles.size();
  if (n == 0) return;
  std::vector<std::size_t> chosen;
  directed_resample_indices(weights, random, chosen);
  std::vector<Particle> next;
  next.reserve(n);
  for (const std::size_t k : chosen) next.push_back(particles[k]);
  for (std::size_t r = 0; next.size() < n; ++r) next.push_back(r == 0 ? board : from_board(random));
  particles = std::move(next);
  weights.assign(n, 1.0 / static_cast<double>(n));
}

/// Particle diversity as paper 001 measures it, made precise: each pose quantised into cells of
/// cell_xy_m and cell_theta_rad, the Hamming distance of two particles the number of the three
/// coordinates whose cells differ (0 to 3), averaged over all pairs. 0: all in one cell.
inline double hamming_diversity(const std::vector<Pose>& poses, double cell_xy_m,
                                double cell_theta_rad) {
  const std::size_t n = poses.size();
  if (n < 2) return 0.0;
  std::vector<Eigen::Vector3d> cells(n);
  for (std::size_t i = 0; i < n; ++i) {
    cells[i] = {std::floor(poses[i](0) / cell_xy_m), std::floor(poses[i](1) / cell_xy_m),
                std::floor(wrap(poses[i](2)) / cell_theta_rad)};
  }
  double sum = 0.0;
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = i + 1; j < n; ++j)
      for (int k = 0; k < 3; ++k) sum += cells[i](k) != cells[j](k) ? 1.0 : 0.0;
  return sum / (0.5 * static_cast<double>(n) * static_cast<double>(n - 1));
}

}  // namespace locsim::sdk
