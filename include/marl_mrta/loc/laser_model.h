// amcl's likelihood-field laser model (amcl_laser.cpp, LikelihoodFieldModel): each used beam's
// end point is looked up in the map's obstacle distances, scored
//   pz = z_hit · exp(-d² / (2 sigma_hit²)) + z_rand / range_max
// and a particle's weight is multiplied by 1 + sum(pz³) (amcl's ad-hoc combination, which
// works better than the product of the pz).
//
// Readings that say nothing are skipped: at or below the minimum range (the LDS-01 driver reports
// no return as 0), at or beyond the maximum range, NaN. The minimum and maximum are the scan's,
// narrowed by laser_min_range / laser_max_range when those are positive.
#pragma once

#include <vector>

#include "marl_mrta/loc/localization_map.h"
#include "marl_mrta/loc/particle_filter.h"

namespace marl_mrta {
namespace loc {

struct LaserModelParams {
  int max_beams = 30;        // evenly spaced beams used per scan (>= 2)
  double z_hit = 0.95;       // mixture weight of the hit term
  double z_rand = 0.05;      // mixture weight of the random term
  double sigma_hit = 0.2;    // [m] standard deviation of the hit term
  double min_range = -1.0;   // [m] > 0: narrows the scan's minimum range
  double max_range = -1.0;   // [m] > 0: narrows the scan's maximum range
};

// One laser scan in the robot's base frame: amcl takes the beams' bearings in the base frame, so
// that a laser mounted upside down or turned works.
struct ScanObservation {
  double laser_x = 0.0, laser_y = 0.0;  // [m] the laser's position in the base frame
  double angle_min = 0.0;               // [rad] bearing of reading 0 in the base frame
  double angle_increment = 0.0;         // [rad] from one reading to the next, in the base frame
  double range_min = 0.0;               // [m] the sensor's limits
  double range_max = 0.0;
  std::vector<float> ranges;            // [m]
};

class LikelihoodFieldModel {
 public:
  LikelihoodFieldModel(const LaserModelParams& params, const LocalizationMap& map);

  // The limits a scan is read with; false (and the scan unusable) when the maximum is not
  // positive or the minimum negative.
  bool effectiveRanges(const ScanObservation& scan, double& range_min, double& range_max) const;
  // Indices of the readings the model uses: every step-th of max_beams, then those in range.
  std::vector<int> usedBeams(const ScanObservation& scan) const;

  // Multiplies every particle's weight by the scan's likelihood at its pose; returns false
  // (weights untouched) for an unusable scan.
  bool weigh(const ScanObservation& scan, std::vector<Particle>& particles);

 private:
  // pz³ for every cell (and outside the map), for the maximum range the table was made for.
  void prepareScores(double range_max);

  LaserModelParams params_;
  const LocalizationMap& map_;
  std::vector<double> cell_score_;
  double outside_score_ = 0.0;
  double scores_range_max_ = -1.0;
  std::vector<double> beam_x_, beam_y_;  // scratch: used end points in the laser's axes
};

}  // namespace loc
}  // namespace marl_mrta
