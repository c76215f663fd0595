// Options of the free-space filter (`freespace`: ray casting) and the tracked filter (`tracked`: the
// Kalman-linked robot body), the methods beyond the paper (docs/beyond.md). Kept apart from filter.hpp
// so MethodOptions can hold them without the filter headers including each other.
#pragma once

#include <cstdint>

namespace teamscan::mapping {

// `freespace`: DUFOMap-style void evidence (ANCHORS.md §2): every ray from a scan's sensor origin to
// its hit marks the voxels it passes through as seen empty; a point whose voxel was seen empty by
// enough rays is transient.
struct FreespaceOptions {
  double resolution_m = 0.05;
  // Vertical grid offset: −r/2 centres a z = 0 floor in one voxel layer (docs/evaluation.md).
  double grid_origin_z_m = -0.025;
  // Rays clear nothing within this distance of the sensor (ANCHORS.md §6.2: ego points, dufomap
  // min_range 0.2 m); hits nearer than it neither mark nor clear.
  double min_range_m = 0.2;
  // Returns beyond this range give no free evidence (LMS-200: 8.182 m is the largest value, §2.7).
  double max_range_m = 8.2;
  // A ray stops this far short of its hit, so its own hit voxel and the one before stay untouched.
  double end_margin_m = 0.1;
  // Grazing rays (ANCHORS.md §6.3): a ray stops where it comes within `clearance_m` (vertically) of its
  // hit's height, i.e. clearance/|sin(elevation)| before the hit, at most `grazing_cap_m` before it.
  // A ray sliding over the floor to a far floor hit thus never enters the floor's voxel layer.
  double clearance_m = 0.05;
  double grazing_cap_m = 1.0;
  // A point is transient when its voxel's free passes >= max(min_free, free_per_hit · hits) (with
  // ray_stride > 1: free ≥ min_free and free · ray_stride ≥ free_per_hit · hits).
  // The ratio keeps surfaces that are hit far more often than rays graze through them.
  std::uint32_t min_free = 2;
  double free_per_hit = 1.0;
  // Partly occupied voxels (ANCHORS.md §6.3, DUFOMap's dilation idea): a table top's edge voxel is
  // also crossed by rays passing just beside the slab. With the guard, a void voxel still counts as
  // static when one of its 6 face neighbours is solid (hit and not void): a surface continues there.
  // A teammate that left has no solid neighbour: its whole body's voxels went void together.
  bool solid_neighbour_guard = true;
  // 6: face neighbours only; 26: also edge and corner neighbours (a table edge at a yaw to the grid
  // is a staircase of voxels whose solid neighbours are often diagonal).
  int guard_neighbours = 26;
  // Rays cast per scan (docs/beyond.md "A cheaper free-space walk"): only every `ray_stride`-th point of
  // a scan casts its ray, from point (scan number mod ray_stride) on, so consecutive scans cast the
  // others. A laser fan is denser than the grid near the sensor (1° beams are 1.7 cm apart at 1 m, the
  // voxels 5 cm). Every point still counts its hit, so a surface's evidence and the solid-neighbour
  // guard are whole; a cast ray stands for `ray_stride` rays: the per-hit demands compare
  // free · ray_stride with free_per_hit · hits, while min_free counts the passes actually cast.
  // 1: every ray. `best` casts every third (MethodOptions::best_freespace).
  std::uint32_t ray_stride = 1;
};

// `tracked`: the paper's position and direction filters made one 3-D body test: every
// teammate is the Pioneer 3-AT's bounding box (sim/world.cpp make_pioneer3at_body: 626 × 505 mm, laser
// housing top at ~0.5 m), oriented by its heading, at its Kalman estimate moved to the beam's time,
// inflated by n·σ of the Kalman position covariance along each box axis and by the heading σ.
struct TrackedOptions {
  double half_length_m = 0.313;
  double half_width_m = 0.2525;
  double height_m = 0.52;
  // Points below this height are never a body hit. The wheels reach z = 0: some ghosts are wheel hits
  // below 1 cm (docs/beyond.md), so by default the box reaches below the floor's noise
  // and takes the few floor points inside the inflated footprint with it.
  double floor_clearance_m = -0.05;
  // Below this height (wheel contact, floor noise) the box is the bare footprint + margin_m, without
  // the covariance and heading inflation: the floor around a teammate is scanned far more than its
  // wheels, and those wheel hits lie within the footprint (lap2: |y| ≤ 0.268 m vs 0.2525 m).
  double low_band_m = 0.02;
  // With the height profile, the low band is only the four wheels' contact strips (sim/world.cpp: wheel
  // centres x ±0.134 m, 215 mm diameter, y from ±0.1425 to ±0.2525 m) + margin: the floor under the
  // chassis (90 mm clearance) and under the bumpers is visible floor a down-laser sees past a teammate.
  double wheel_half_length_m = 0.2415;
  // Margin of the wheel strips: 4σ of the 5 mm range noise of a wheel-face hit (< 0: margin_m); the
  // pose error is covered by the Kalman σ. The floor beside a wheel is scanned far more than the
  // wheel's lowest 2 cm, so this margin costs floor (docs/beyond.md has the figures).
  double low_margin_m = 0.02;
  double wheel_inner_y_m = 0.1425;
  // Floor-consistent low points (docs/beyond.md "Floor beside the wheels"): a point whose height is
  // within `low_floor_n_sigma` σ_z of the floor is explained by the floor AND by the bottom of a wheel
  // face. The floor is the map frame's z = 0 plane (the odometry is 2-D on a flat floor), so a floor
  // point's height error is the range noise's vertical part only: σ_z = range_noise_m · |sin elevation|
  // of its beam (5 mm · sin 25° ≈ 2 mm for a laser pitched 25°). The floor is there around every
  // wheel, the wheel face's lowest millimetres are a small target, so such a point counts as a wheel
  // hit only at the wheel's estimated outline + `low_outline_margin_m` (2σ of the range noise, no
  // pose σ), not anywhere in the σ-inflated strip. A low point above the floor's noise is not floor,
  // and the whole strip takes it. low_floor_n_sigma < 0 or low_outline_margin_m < 0: off, the whole
  // strip takes every low point.
  double low_floor_n_sigma = 3.0;
  double range_noise_m = 0.005;  // the LMS-200's range σ (sim/scenario.hpp range_noise_mm)
  double low_outline_margin_m = 0.01;
  // The body's height profile (sim/world.cpp make_pioneer3at_body): up to the top plate (277 mm) the
  // full footprint; above it only the LMS-200 housing and its post stand, 156 × 155 mm around the
  // mount (x 0.125 m; housing centre 15 mm behind it, pitched ±20°: x from −0.027 to 0.247 m). A
  // surface above the top plate next to a teammate (a coffee-table top at 0.40 m beside which a robot
  // drives) is therefore outside the box unless it is at the housing. Off: one box up to height_m.
  bool height_profile = true;
  double upper_z_m = 0.277;
  double upper_centre_x_m = 0.11;
  double upper_half_length_m = 0.137;
  double upper_half_width_m = 0.08;
  // Whether the box takes the odometry drift (TrackerOptions::drift_*: the teammate's and the scanning
  // robot's own) on top of the Kalman covariance. `best` uses both: the box without drift decides
  // alone, the band the drift adds needs the map's free-space evidence too (best.hpp).
  bool include_drift = true;
  double margin_m = 0.04;           // range noise, quantisation, odometry between poses
  double n_sigma = 3.0;
  double heading_sigma_rad = 0.035; // ~2°: heading is not in the tracker's state
  // Beams of one scan span one sweep ending at the scan's stamp (common/dataset ScanRecord): beam i
  // of n is taken at stamp − sweep·(1 − (i + ½)/n). 13.3 ms = one 75 Hz mirror revolution.
  double sweep_s = 0.0133;
};

}  // namespace teamscan::mapping
