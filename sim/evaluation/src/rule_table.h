// Private: the rules the Evaluator implements, by index, with the thresholds each one reads.
// The numbers themselves live in data/evaluation/rules.json; this table only says which names
// a rules file must give, so that a file is checked once, at load, with the file and key named.
#pragma once

#include <array>
#include <initializer_list>

namespace forklift::evaluation {

enum RuleKey : int {
  kCollisionPedestrian,
  kCollisionInWalkway,
  kViolentCollision,
  kCollisionRack,
  kCollisionLorry,
  kCollisionStructure,
  kCollisionCone,
  kCollisionPallet,
  kForkStrikePallet,
  kSpeedOpenAisle,
  kSpeedNearWalkway,
  kSpeedCorner,
  kTravelForksHigh,
  kTravelForksLow,
  kTravelTiltedForwardLaden,
  kTurnAtSpeed,
  kTurnAtSpeedLoadRaised,
  kHarshBrakingLoadRaised,
  kStabilityWarning,
  kWheelLift,
  kTipOver,
  kLoadDropped,
  kLoadSlid,
  kOverload,
  kWheelsNotStraightStacking,
  kSetDownOffPlace,
  kUnsafeStacking,
  kParkedForksRaised,
  kParkedControlsNotNeutral,
  kOffRoute,
  kTimeLimit,
  kTaskIncomplete,
  kDeadmanStop,
  kPedestrianStruck,
  kSpeedNearPedestrian,
  kPedestrianInPath,
  kHornAtMarker,
  kSpeedAtMarker,
  kPedestrianAtFixedObject,
  kPersonUnderForks,
  kCollisionTruck,
  kGiveWayAtCrossing,
  kNumRules
};

// What a rule's applies_to lists.
enum class AppliesTo { kNothing, kObjectKinds, kZoneKinds, kMarkerKinds };

struct RuleSpec {
  const char* id;
  AppliesTo applies;
  std::initializer_list<const char*> thresholds;
};

// In RuleKey order.
inline const std::array<RuleSpec, kNumRules>& rule_specs() {
  static const std::array<RuleSpec, kNumRules> specs{{
      {"collision_pedestrian", AppliesTo::kObjectKinds, {"clear_time_s"}},
      {"collision_in_walkway", AppliesTo::kZoneKinds, {"clear_time_s"}},
      {"violent_collision", AppliesTo::kNothing, {"impact_speed_m_s"}},
      {"collision_rack", AppliesTo::kObjectKinds, {"hard_impact_speed_m_s", "hard_impact_worry_level", "clear_time_s"}},
      {"collision_lorry", AppliesTo::kObjectKinds, {"hard_impact_speed_m_s", "hard_impact_worry_level", "clear_time_s"}},
      {"collision_structure", AppliesTo::kObjectKinds, {"hard_impact_speed_m_s", "hard_impact_worry_level", "clear_time_s"}},
      {"collision_cone", AppliesTo::kObjectKinds, {"hard_impact_speed_m_s", "hard_impact_worry_level", "clear_time_s"}},
      {"collision_pallet", AppliesTo::kObjectKinds, {"hard_impact_speed_m_s", "hard_impact_worry_level", "clear_time_s"}},
      {"fork_strike_pallet", AppliesTo::kNothing, {"hard_impact_speed_m_s", "hard_impact_worry_level", "clear_time_s"}},
      {"speed_open_aisle", AppliesTo::kZoneKinds, {"over_limit_m_s", "min_duration_s", "clear_time_s"}},
      {"speed_near_walkway", AppliesTo::kZoneKinds, {"near_distance_m", "over_limit_m_s", "min_duration_s", "clear_time_s"}},
      {"speed_corner", AppliesTo::kZoneKinds, {"over_limit_m_s", "min_duration_s", "clear_time_s"}},
      {"travel_forks_high", AppliesTo::kNothing, {"fork_height_max_m", "travel_speed_min_m_s", "min_duration_s", "clear_time_s"}},
      {"travel_forks_low", AppliesTo::kNothing, {"fork_clearance_min_m", "travel_speed_min_m_s", "min_duration_s", "clear_time_s"}},
      {"travel_tilted_forward_laden", AppliesTo::kNothing, {"tilt_forward_max_deg", "travel_speed_min_m_s", "min_duration_s", "clear_time_s"}},
      {"turn_at_speed", AppliesTo::kNothing, {"lateral_acceleration_max_m_s2", "min_duration_s", "clear_time_s"}},
      {"turn_at_speed_load_raised", AppliesTo::kNothing, {"lateral_acceleration_max_m_s2", "raised_fork_height_m", "min_duration_s", "clear_time_s"}},
      {"harsh_braking_load_raised", AppliesTo::kNothing, {"deceleration_max_m_s2", "raised_fork_height_m", "min_duration_s", "clear_time_s"}},
      {"stability_warning", AppliesTo::kNothing, {"warn_below_fraction", "clear_above_fraction", "min_duration_s", "clear_time_s"}},
      {"wheel_lift", AppliesTo::kNothing, {"wheel_load_min_N", "min_duration_s", "clear_time_s"}},
      {"tip_over", AppliesTo::kNothing, {}},  // the truck file's tipped_over_deg
      {"load_dropped", AppliesTo::kNothing, {}},
      {"load_slid", AppliesTo::kNothing, {"slide_min_m", "clear_time_s"}},
      {"overload", AppliesTo::kNothing, {"tolerance_fraction", "clear_time_s"}},
      {"wheels_not_straight_stacking", AppliesTo::kNothing, {"steer_max_deg"}},
      {"set_down_off_place", AppliesTo::kNothing, {}},
      {"unsafe_stacking", AppliesTo::kNothing, {"overhang_max_m"}},
      {"parked_forks_raised", AppliesTo::kNothing, {"lift_max_m"}},
      {"parked_controls_not_neutral", AppliesTo::kNothing, {"speed_max_m_s", "control_max_fraction"}},
      {"off_route", AppliesTo::kNothing, {"beyond_edge_m", "min_duration_s", "clear_time_s"}},
      {"time_limit", AppliesTo::kNothing, {}},
      {"task_incomplete", AppliesTo::kNothing, {}},
      {"deadman_stop", AppliesTo::kNothing, {}},
      {"pedestrian_struck", AppliesTo::kNothing, {"clear_time_s"}},
      {"speed_near_pedestrian", AppliesTo::kNothing, {"near_distance_m", "speed_max_m_s", "min_duration_s", "clear_time_s"}},
      {"pedestrian_in_path", AppliesTo::kNothing, {"travel_speed_min_m_s", "reaction_time_s", "braking_deceleration_m_s2",
                                                   "margin_m", "lateral_margin_m", "min_duration_s", "clear_time_s"}},
      {"horn_at_marker", AppliesTo::kMarkerKinds, {"horn_before_s", "horn_after_s", "clear_time_s"}},
      {"speed_at_marker", AppliesTo::kMarkerKinds, {"walking_pace_m_s", "min_duration_s", "clear_time_s"}},
      {"pedestrian_at_fixed_object", AppliesTo::kNothing, {"travel_speed_min_m_s", "near_distance_m", "object_within_m",
                                                           "lateral_margin_m", "min_duration_s", "clear_time_s"}},
      {"person_under_forks", AppliesTo::kNothing, {"raised_fork_height_m", "margin_m", "min_duration_s", "clear_time_s"}},
      {"collision_truck", AppliesTo::kNothing, {"hard_impact_speed_m_s", "hard_impact_worry_level", "clear_time_s"}},
      {"give_way_at_crossing", AppliesTo::kNothing, {"priority_within_m", "clear_time_s"}},
  }};
  return specs;
}

// The collision rules chosen by the kind of object struck (their applies_to must cover every
// object kind exactly once).
inline constexpr std::array<RuleKey, 6> kObjectCollisionRules{kCollisionPedestrian, kCollisionRack, kCollisionLorry,
                                                              kCollisionStructure, kCollisionCone, kCollisionPallet};
// The speed rules chosen by the kind of zone that sets the limit.
inline constexpr std::array<RuleKey, 3> kSpeedRules{kSpeedOpenAisle, kSpeedNearWalkway, kSpeedCorner};

}  // namespace forklift::evaluation
