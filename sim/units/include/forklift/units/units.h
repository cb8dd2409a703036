// Physical constants and unit conversions, each written once. Everything inside the simulation
// is SI (metres, kilograms, seconds, radians); degrees are for files a person writes and for
// what a person reads.
#pragma once

#include <cmath>

namespace forklift {

// Standard gravity as the paper and the truck files take it, m/s^2 (world -z on level ground).
inline constexpr double kGravity_m_s2 = 9.81;

// One degree in radians: `88 * kDeg` is 88 degrees; an angle in degrees is `rad / kDeg`.
inline constexpr double kDeg = M_PI / 180.0;
// One radian in degrees, for code that converts by multiplying: `rad * kRad` is in degrees.
inline constexpr double kRad = 180.0 / M_PI;

}  // namespace forklift
