// The warehouse (the paper's Virtual Scene): the objects a scenario file places, their meshes
// loaded with assimp, the floor's ramps, the speed zones and walkways, the route and the task.
// Loaded once per session and then const; what moves at run time (a pallet picked up and set
// down elsewhere) is tracked by the pallet handler (collision.h), not here.
//
// Frames: world x, y on the floor, z up, metres. Every object has a local frame whose origin
// lies on the floor (z = 0 of the object) at the middle of its footprint, x along its length.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "forklift/dynamics/dynamics.h"  // Ground, Ramp, TruckParams, BodyPoses
#include "forklift/scene/scenario.h"  // Scenario (truck, start, load)

namespace forklift {

// Anything wrong with a scene, scenario or mesh file; the message names the file and the key.
class SceneError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// One part of a mesh (an OBJ group, a glTF node): triangles in the owner's local frame.
// Our meshes are built of boxes, one box per part, so a solid part's bounds are its collision
// box exactly; parts named "mark_*" (floor paint, signs) are drawn but never collided.
struct MeshPart {
  std::string name;
  std::vector<Eigen::Vector3f> positions;  // per vertex
  std::vector<Eigen::Vector3f> normals;    // per vertex, unit
  std::vector<uint32_t> triangles;         // 3 vertex indices per triangle
  Eigen::Vector3f colour{0.7f, 0.7f, 0.7f};  // the material's diffuse RGB, 0..1
  Eigen::AlignedBox3d bounds;              // of the positions, local frame
  bool solid = true;                       // false for "mark_*" parts
};

struct Mesh {
  std::string source;  // the file it was loaded from
  std::vector<MeshPart> parts;
  Eigen::AlignedBox3d bounds;
};

// Loads an OBJ or glTF file with assimp (triangulated, normals generated where missing).
// Throws SceneError naming the file for a missing, unreadable or empty file.
std::shared_ptr<const Mesh> load_mesh(const std::string& path);

enum class ObjectKind { kRack, kPallet, kWall, kDoor, kDock, kLorry, kCone, kObstacle, kPedestrian };
const char* object_kind_name(ObjectKind kind);  // "rack", "pallet", ... as in scenario files
std::optional<ObjectKind> parse_object_kind(const std::string& name);

// A surface a pallet can be set down on: a rack level's beams, a lorry's bed, a dock's top.
// The floor (the ground) is always one and is not listed.
struct Support {
  std::string name;               // "level 2", "bed"
  int level = 0;                  // racks: 1 = the first beam level above the floor; 0 otherwise
  Eigen::AlignedBox2d footprint;  // local x, y
  double height_m = 0;            // top of the surface above the object's local z = 0
};

// A pallet and what it carries. The local x axis is the fork-entry direction (forks enter
// through the faces at x = +-length/2); pockets run the whole length.
struct PalletSpec {
  double length_m = 1.2, width_m = 0.8, height_m = 0.144;  // EUR pallet (EN 13698-1)
  double pocket_bottom_m = 0.022, pocket_top_m = 0.122;    // above the pallet's underside
  std::vector<Eigen::Vector2d> pockets_y_m;  // each pocket's lateral extent [min, max], local y
  double pallet_mass_kg = 25;
  double load_mass_kg = 0;
  Eigen::Vector3d load_size_m = Eigen::Vector3d::Zero();  // box on the deck, centred; zero: none
  // On the forks' steel; NaN: the truck's load_contact (wooden pallets, data/trucks/*.json).
  double friction_static = NAN, friction_kinetic = NAN;
};

struct SceneObject {
  std::string id;  // unique in the scene: "R2", "P3", "cone_4"
  ObjectKind kind = ObjectKind::kObstacle;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();  // world from local
  std::shared_ptr<const Mesh> mesh;
  std::vector<Support> supports;       // racks, lorries, docks
  std::optional<PalletSpec> pallet;    // pallets
  bool collidable = true;
  // Added: pallets with a load (pallet->load_size_m not zero): the unit load box (meshes/
  // load_box.obj, x and y in [-0.5, 0.5], z in [0, 1]) to scale by load_size_m and stand on the
  // deck, centred; null otherwise.
  std::shared_ptr<const Mesh> load_mesh;
  // Added: pallets: the object and support level the pallet stands on at the start ("" and 0:
  // the floor), as the scenario file's "on" and "level" give them.
  std::string rests_on;
  int rest_level = 0;
};

// Where a pallet is now (moved at run time by the Warehouse, collision.h; drawn by the renderer).
struct PalletState {
  std::string id;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();  // world from the pallet's local frame
  bool on_forks = false;
  double slide_m = 0;        // how far it has slid along the forks since it was picked up (+ towards the tips)
  bool dropped = false;      // fell off the forks; it lies where it fell
  std::string resting_on;    // object id it stands on ("" for the floor)
  int level = 0;             // the rack level it stands on (0: floor or a single support)
};

// A floor area with a speed limit: "aisle", "walkway" (marked pedestrian walkway), "corner",
// "dock", "yard". Where zones overlap the lowest limit applies.
struct Zone {
  std::string id, kind;
  std::vector<Eigen::Vector2d> polygon;  // world, counter-clockwise
  double speed_limit_m_s = 0;
  bool contains(const Eigen::Vector2d& p) const;
};

// A marked place where the driver cannot see what is coming: a blind corner, a door, a cross
// aisle. Entering its area the driver must have sounded the horn and keep to walking pace
// (the evaluation's horn_at_marker and speed_at_marker; OSHA 1910.178(n)(4)).
struct Marker {
  std::string id, kind;                  // kind: one of marker_kinds()
  std::vector<Eigen::Vector2d> polygon;  // world, counter-clockwise: where the horn and the slow pace are due
  bool contains(const Eigen::Vector2d& p) const;
};
// "blind_corner", "door", "cross_aisle".
const std::vector<std::string>& marker_kinds();

// A spill on the floor (oil, water): a patch where the tyres grip less. It is in `Scene::ground`
// (GripPatch, dynamics.h, at the same index), which the dynamics read; listed here with its id
// for drawing. One with a trigger is not on the floor until it fires (or the instructor's
// "hazard" names it): whether it has appeared is the session's state (spills.h).
struct Spill {
  std::string id;
  Eigen::AlignedBox2d rect;   // world x, y
  double friction_scale = 1;  // (0, 1]: the tyres' friction inside it, as a share of their own
  bool triggered = false;     // false: on the floor from the start
  // Appears when the truck's outline comes within this distance of the patch's middle (set), or at start_at_s.
  std::optional<double> start_truck_within_m;
  double start_at_s = 0;
};
// A spill with a trigger must be among the first kMaxTriggeredSpill spills (the dynamics hold
// which are absent as the bits of a word).
constexpr size_t kMaxTriggeredSpill = 64;

// The marked route: a polyline with a width; leaving it is a fault (evaluation).
struct Route {
  std::vector<Eigen::Vector2d> points;
  double width_m = 0;  // zero: no route
};

// The task, as ordered steps. "reach": drive into a circle. "pass": go through a gate between
// two points (slalom, doors). "move": take pallet `pallet` and set it down on `to_object`
// (`to_level` for racks, 0 = the object's only support; to_object empty = the floor inside
// `area`), within `tolerance_m` of the target's centre. "control": a lesson's step, done when the
// pupil has worked one control (`action`) as far as `amount` says (see ControlAction).
struct TaskStep {
  std::string kind;  // "reach", "pass", "take" (a pallet picked up: de-stacking), "move", "control"
  std::string description;
  Eigen::Vector2d point = Eigen::Vector2d::Zero();
  double radius_m = 0;
  Eigen::Vector2d gate_a = Eigen::Vector2d::Zero(), gate_b = Eigen::Vector2d::Zero();
  std::string pallet, to_object;
  int to_level = 0;
  Eigen::AlignedBox2d area;
  double tolerance_m = 0.15;
  // A move may also ask the pallet set down square to a heading: within yaw_tolerance_rad of
  // yaw_rad (either way round: a pallet has two faces). Unset: any heading.
  std::optional<double> yaw_rad;
  double yaw_tolerance_rad = 0;
  // A control step: what is to be worked, and how far (SI: m/s, rad or m, as the action's key says).
  std::string action;
  double amount = 0;
};

// A lesson's control steps: the action, the scenario key that gives its amount, and whether the
// truck must reach at least that amount (speed forward or back, the rear wheel turned, the forks
// lifted, the mast tilted) or come within it (stopped, the wheel straight, the forks down, the
// mast level). The evaluator judges them, so every cab gets the same lesson.
struct ControlAction {
  const char* name;    // "forward", "stop", "reverse", "steer_left", ...
  const char* key;     // "speed_m_s", "angle_deg" or "height_m"
  bool at_least;       // true: the measure reaches the amount; false: it falls within it
};
const std::vector<ControlAction>& control_actions();
const ControlAction* find_control_action(const std::string& name);  // nullptr if none

struct Task {
  std::string summary;  // one line a pupil reads: "Take P3 from R2 level 2 to dock bay 1"
  std::vector<TaskStep> steps;
};

// The truck's shape for drawing and collision: a mesh per rigid part, each in the frame
// BodyPoses gives for it (chassis: geometry frame; mast: tilt pivot; carriage: fork heel).
// Wheel meshes are centred on the wheel, axle along y. Built from the truck file, so the
// wheels, the wheelbase and the mast pivot are the ones the dynamics use.
struct TruckShape {
  std::shared_ptr<const Mesh> chassis, mast, carriage, front_wheel, rear_wheel;
  double fork_length_m = 1.0, fork_width_m = 0.1, fork_thickness_m = 0.04;
  double fork_centres_y_m = 0.36;  // fork centre to fork centre; forks at +-half of it
  // Driver's eye in the geometry frame (for the cab view).
  Eigen::Vector3d eye_m = Eigen::Vector3d(-0.75, 0.0, 1.75);
};

// How far the driver may turn the head from straight ahead at the eye point (the ranges of
// protocol/idl/Forklift.idl's look_yaw_rad and look_pitch_rad: the cab checks, the renderer clamps).
inline constexpr double kLookYawMaxRad = 2.6;    // + left
inline constexpr double kLookPitchMaxRad = 0.6;  // + up

// A scenario laid out as a recognised practical test: only these start in exam mode (the worker
// and the server refuse others). Its marking sheet is data/evaluation/rules.json; `standard`
// says what the course follows (data/evaluation/README.md traces each item to its source).
struct ExamCourse {
  std::string title;     // "Counterbalance truck practical test"
  std::string standard;  // what the layout and the marking follow, in words
};

// Why `what` (a scenario file, or a name) cannot start an exam: only a scenario marked as an
// exam course does. The worker and the server both say this.
std::string not_an_exam_course(const std::string& what);

// A person who walks a path through the warehouse (a scenario's `pedestrians`): how one walks,
// and the state that changes, are pedestrians.h's.
struct PedestrianWait {
  int at_point = 0;        // index into the path
  double duration_s = 0;   // stands this long on reaching it
};
struct PedestrianSpec {
  std::string id;                     // unique among the scene's objects and pedestrians
  std::vector<Eigen::Vector2d> path;  // world, at least 2 points: walked once, first to last, then stands
  double speed_m_s = 0;               // walking speed, > 0
  std::vector<PedestrianWait> waits;  // at most one per path point
  // Starts walking when the truck's outline comes within this distance (set), or at start_at_s.
  std::optional<double> start_truck_within_m;
  double start_at_s = 0;
  // Looks: stands still while the truck's outline is within stop_within_m; one who does not
  // look walks on whatever the truck does.
  bool looks = true;
  double stop_within_m = 0;
  // One who does not look may still hear: the horn sounded with the truck's outline within this
  // distance alerts him, and from then on he stands while the truck is that near (as one who looks).
  std::optional<double> heeds_horn_within_m;
  Eigen::Vector3d size_m{0.5, 0.3, 1.75};  // shoulders across, chest to back, height: an upright box
};

// A pallet that falls from the rack level it stands on when its trigger fires (a scenario's
// `falling_pallets`; falling.h drops it): it slides throw_m off the beams along toward_rad as it
// drops to the floor below, and lies there, fallen.
struct FallingPalletSpec {
  std::string pallet;  // a pallet object's id, standing on a support above the floor
  // Falls when the truck's outline comes within this distance of the pallet's middle (set), or at start_at_s.
  std::optional<double> start_truck_within_m;
  double start_at_s = 0;
  double toward_rad = 0;  // world heading of its slide off the beams
  double throw_m = 0.8;   // how far it lands from under where it stood
};

// A marked crossing of traffic routes (a scenario's `crossings`): who goes first there is the
// site's traffic rule, which the scenario states. "pupil": the other trucks give way to the
// pupil's truck (traffic.h stops them short of it while the pupil's truck is within watch_m of
// its middle); "traffic": the pupil gives way to them (the evaluation's give_way_at_crossing).
struct Crossing {
  std::string id;
  std::vector<Eigen::Vector2d> polygon;  // world, counter-clockwise
  std::string priority;                  // "pupil" or "traffic"
  double watch_m = 0;                    // "pupil": how near the pupil's truck holds the traffic back
  Eigen::Vector2d middle_m = Eigen::Vector2d::Zero();  // the mean of the polygon's corners
  bool contains(const Eigen::Vector2d& p) const;
};

// Another truck driven along a route (a scenario's `trucks`): how it drives, and the state that
// changes, are traffic.h's.
struct OtherTruckSpec {
  std::string id;                      // unique among the objects, pedestrians and trucks
  std::vector<Eigen::Vector2d> route;  // world, at least 2 points: the body's middle drives along it
  double speed_m_s = 0;                // driving speed, > 0
  bool loop = false;                   // after the last point back to the first, and round again
  // Starts when the pupil's truck's outline comes within this distance (set), or at start_at_s.
  std::optional<double> start_truck_within_m;
  double start_at_s = 0;
  // Its driver looks ahead: it stands while the pupil's truck's outline is within this distance
  // of the middle of its front (set); unset, it drives on whatever is ahead.
  std::optional<double> stop_within_m;
  Eigen::Vector3d size_m{3.0, 1.1, 2.1};  // length, width, height: an upright box facing its way
};

struct Scene {
  std::string file, name, description;
  std::optional<ExamCourse> exam_course;  // set: the scenario is an exam course
  Scenario scenario;  // truck file, start pose, initial load (scenario.h)
  Ground ground;      // ramps, and steps: docks, kerbs, lorry beds, the yard below a dock
  std::vector<SceneObject> objects;
  std::vector<Zone> zones;
  std::vector<Marker> markers;  // blind corners, doors, cross aisles
  std::vector<Spill> spills;    // in `ground` too
  std::vector<FallingPalletSpec> falling_pallets;
  Route route;
  Task task;
  double time_limit_s = 0;  // zero: none
  Eigen::AlignedBox2d floor;  // the warehouse floor drawn (world x, y)
  // Added: the ramps and steps `ground` is built from, for drawing.
  std::vector<Ramp> ramps;
  std::vector<GroundStep> ground_steps;
  std::vector<PedestrianSpec> pedestrians;  // people who move (pedestrians.h walks them)
  std::vector<OtherTruckSpec> trucks;       // other trucks on their routes (traffic.h drives them)
  std::vector<Crossing> crossings;          // where routes cross, and who goes first

  const SceneObject* find(const std::string& id) const;  // nullptr if absent
  // The lowest speed limit of the zones containing p, or nullopt outside every zone.
  std::optional<double> speed_limit(const Eigen::Vector2d& p) const;
};

// Reads a scenario file (data/scenarios/*.json; format in data/scenarios/README.md) and the
// meshes it names, relative to data_dir. A manoeuvre file (no "objects") is an empty floor.
// Throws SceneError naming the file and the key.
Scene load_scene(const std::string& path, const std::string& data_dir);

// The truck's meshes, built of boxes from its truck file: the wheels (radii, wheelbase, track),
// the mast pivot and the fork heel from the sections load_truck reads, the body, guard, mast,
// carriage and wheel widths from its "shape" section. Nothing is read from data_dir (kept for
// the callers). Throws SceneError naming the file and the key.
TruckShape load_truck_shape(const std::string& truck_file, const std::string& data_dir);

// Added: writes every warehouse mesh the data folder ships (OBJ + MTL, built from boxes) into
// `dir`, which must exist; the same bytes every time. Returns the OBJ file names written
// ("rack.obj", ...). `forklift-sim meshes --out DIR` calls it; data/meshes/ holds its output.
// Throws SceneError.
std::vector<std::string> write_meshes(const std::string& dir);

// Mesh files are read and written by assimp, loaded the first time one is (a module of its own,
// about 10 ms to map and relocate). A program that will read some soon can load it now, on a
// thread of its own, while it does something else. Throws SceneError if it cannot be loaded.
void preload_mesh_files();

// Writes the truck's meshes as load_truck_shape builds them (truck_chassis.obj, truck_mast.obj,
// truck_carriage.obj, truck_wheel_front.obj, truck_wheel_rear.obj, each with its .mtl) into
// `dir`, for viewing elsewhere; nothing reads them back. Throws SceneError.
std::vector<std::string> write_truck_meshes(const std::string& truck_file, const std::string& dir);

}  // namespace forklift
