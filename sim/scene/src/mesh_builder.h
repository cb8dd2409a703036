// The warehouse's and the truck's meshes, built from boxes (and a few prisms for wheels), and
// their OBJ writer. Private to the scene module; the public entry points are write_meshes(),
// load_truck_shape() and write_truck_meshes() in scene.h.
//
// Every mesh is in its owner's local frame (scene.h: origin on the floor at the middle of the
// footprint, x along the length; truck meshes in the frame BodyPoses gives for each part).
// One box per solid part, so a part's bounds are its collision box exactly. The warehouse's
// dimensions live here and data/meshes/ holds this code's output; the truck's come from its
// truck file (TruckDrawing) and are built at load time.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>
#include <vector>

namespace forklift::meshgen {

// A named diffuse colour; meshes share materials by name.
struct Colour {
  std::string name;
  Eigen::Vector3f rgb;
};

// One part: flat-shaded polygons (each face has its own corners, so normals stay sharp).
struct Part {
  std::string name;
  Colour colour;
  std::vector<Eigen::Vector3f> positions;
  std::vector<Eigen::Vector3f> normals;
  std::vector<std::vector<uint32_t>> faces;  // counter-clockwise seen from outside
};

struct MeshSpec {
  std::string file;  // "rack.obj"
  std::vector<Part> parts;
};

// An axis-aligned box part between corners lo and hi (local frame).
Part box(const std::string& name, const Eigen::Vector3f& lo, const Eigen::Vector3f& hi, const Colour& colour);

// A prism approximating a cylinder whose axis is y, centred at `centre`; its bounds are exactly
// [centre - (r, w/2, r), centre + (r, w/2, r)] (vertices on the axis-aligned extremes).
Part cylinder_y(const std::string& name, const Eigen::Vector3f& centre, float radius, float width, int sides,
                const Colour& colour);

// Every warehouse mesh the data folder ships, in a fixed order.
std::vector<MeshSpec> all_meshes();

// The truck's dimensions as drawn, read from its truck file: the wheels and the mast pivot from
// the sections the dynamics read (TruckParams), the rest from its "shape" section. Geometry
// frame (origin on the ground below the middle of the front axle) unless a field says otherwise.
struct TruckDrawing {
  struct Wheel {
    Eigen::Vector3f centre;  // geometry frame; the front mesh is drawn at the left wheel's
    float radius, width;
  };
  Wheel front, rear;
  float hub_radius_share, hub_proud;  // hub radius / tyre radius; hub beyond each tyre face
  Eigen::Vector3f mast_pivot;            // geometry frame
  Eigen::Vector3f fork_heel_from_pivot;  // mast frame, forks lowered
  struct Body {
    float rear, front, half_width, underside, hood, top, cowl_bottom, front_frame_top;
    Eigen::Vector3f front_well_clearance, rear_well_clearance;  // around each wheel: x, y, above
  } body;
  struct Seat {
    float rear, front, half_width, cushion, back_rear, back_front, back_top;
  } seat;
  struct SteeringWheel {
    float rear, front, radius, bottom, top, column_rear, column_front, column_half_width;
  } steering;
  struct Guard {
    float rear, front, roof_bottom, roof_top, post, front_post_rear;
    int slats;
    float slat_pitch, slat_width, slat_thickness, first_slat;
  } guard;
  struct Mast {  // tilt-pivot frame, but the foot and the built height are above the floor
    float foot, built_height, channel_rear, channel_front, channel_inner_y, channel_outer_y;
    float cross_member_depth, top_cross_member, middle_cross_member_bottom, middle_cross_member_top;
    float cylinder_rear, cylinder_front, cylinder_half_width, cylinder_bottom, cylinder_top;
    // Each lift cylinder's axis from the middle: 0, one cylinder in the middle; else two, one
    // either side (a clear-view mast's, behind its channels).
    float cylinder_axis_y = 0;
  } mast;
  struct Carriage {  // fork-heel frame
    float half_width, plate_depth, plate_height, backrest_height, backrest_frame;
    std::vector<float> backrest_bars_y;
    float backrest_bar_width;
    float inner_mast_rear, inner_mast_front, inner_mast_inner_y, inner_mast_outer_y, inner_mast_bottom,
        inner_mast_top_member;
  } carriage;
  float fork_length, fork_width, fork_thickness, fork_centres_y;
};

// The truck's five meshes: chassis, mast, carriage, front wheel, rear wheel (file names
// truck_*.obj for an export).
std::vector<MeshSpec> truck_meshes(const TruckDrawing& truck);

// Writes dir/<spec.file> and its .mtl with assimp's OBJ exporter. Deterministic: the same spec
// gives the same bytes. Throws std::runtime_error naming the file on failure.
void write_obj(const MeshSpec& spec, const std::string& dir);

}  // namespace forklift::meshgen
