// Private: CPU-side triangle batches, polygon triangulation and the painted floor.
#include "geometry.h"

#include <algorithm>
#include <cmath>

namespace forklift::render {
namespace {

using Eigen::Vector2d;
using Eigen::Vector3d;
using Eigen::Vector3f;

uint8_t to_byte(float c) { return uint8_t(std::clamp(c, 0.0f, 1.0f) * 255.0f + 0.5f); }

double cross(const Vector2d& o, const Vector2d& a, const Vector2d& b) {
  return (a - o).x() * (b - o).y() - (a - o).y() * (b - o).x();
}

double signed_area(const std::vector<Vector2d>& p) {
  double a = 0;
  for (size_t i = 0, j = p.size() - 1; i < p.size(); j = i++) a += p[j].x() * p[i].y() - p[i].x() * p[j].y();
  return 0.5 * a;
}

// Inside or on the edge of the counter-clockwise triangle abc.
bool in_triangle(const Vector2d& p, const Vector2d& a, const Vector2d& b, const Vector2d& c) {
  constexpr double kEps = -1e-12;
  return cross(a, b, p) >= kEps && cross(b, c, p) >= kEps && cross(c, a, p) >= kEps;
}

// Floor colours by zone kind; anything else gets a neutral blue-grey so it still shows.
Vector3f zone_colour(const std::string& kind) {
  if (kind == "aisle") return {0.62f, 0.62f, 0.60f};
  if (kind == "walkway") return {0.20f, 0.55f, 0.28f};
  if (kind == "corner") return {0.78f, 0.56f, 0.36f};
  if (kind == "dock") return {0.50f, 0.46f, 0.40f};
  if (kind == "yard") return {0.33f, 0.34f, 0.36f};
  if (kind == "ramp") return {0.47f, 0.48f, 0.50f};
  return {0.52f, 0.55f, 0.62f};
}

// Paint layers above the floor's top (z = 0), far enough apart for a 24-bit depth buffer with
// the renderer's 0.1 m near plane out to about 80 m (resolution z^2 / (near 2^24): 4 mm at
// 80 m). Walkways lie over aisles, corners over both.
double zone_height(const std::string& kind) {
  if (kind == "walkway") return 0.015;
  if (kind == "corner") return 0.010;
  return 0.005;
}

constexpr double kEdgeLineHeight = 0.003;  // above its zone
constexpr double kRouteHeight = 0.021;
constexpr double kTaskHeight = 0.024;      // task markers, above the ground's height where it is raised
constexpr double kRampLift = 0.03;         // above the floor's paint, so the ramp's toe never fights it
const Vector3f kFloorColour{0.56f, 0.56f, 0.54f};
const Vector3f kAisleLine{0.93f, 0.78f, 0.10f};
const Vector3f kWalkwayLine{0.95f, 0.95f, 0.92f};
const Vector3f kRouteLine{0.95f, 0.95f, 0.95f};
const Vector3f kRampColour{0.47f, 0.48f, 0.50f};
const Vector3f kTaskColour{0.15f, 0.50f, 0.95f};  // where the task sends the pupil
constexpr double kTaskLineWidth = 0.12;
constexpr int kRingSegments = 32;

void add_ramps(const Ground& ground, const Eigen::AlignedBox2d& area, Geometry& out) {
  // Sample the ground on a 0.25 m grid; emit only the 0.5 m cells where any sample is raised.
  constexpr double kStep = 0.25;
  constexpr double kRaised = 1e-4;
  const int nx = int(std::ceil(area.sizes().x() / kStep)) + 1;
  const int ny = int(std::ceil(area.sizes().y() / kStep)) + 1;
  if (nx < 2 || ny < 2 || double(nx) * ny > 4e6) return;
  std::vector<double> h(size_t(nx) * ny);
  bool any = false;
  auto node = [&](int i, int j) { return Vector2d(area.min().x() + i * kStep, area.min().y() + j * kStep); };
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const Vector2d p = node(i, j);
      h[size_t(j) * nx + i] = ground.height(p.x(), p.y());
      any = any || std::abs(h[size_t(j) * nx + i]) > kRaised;
    }
  if (!any) return;
  auto vertex = [&](int i, int j) {
    const Vector2d p = node(i, j);
    const Vector2d g = ground.gradient(p.x(), p.y());
    out.add_vertex(Vector3d(p.x(), p.y(), h[size_t(j) * nx + i] + kRampLift),
                   Vector3d(-g.x(), -g.y(), 1.0).normalized(), kRampColour, Pattern::kPlain);
  };
  for (int cj = 0; cj + 2 < ny; cj += 2)
    for (int ci = 0; ci + 2 < nx; ci += 2) {
      bool raised = false;
      for (int j = cj; j <= cj + 2; ++j)
        for (int i = ci; i <= ci + 2; ++i) raised = raised || std::abs(h[size_t(j) * nx + i]) > kRaised;
      if (!raised) continue;
      for (int j = cj; j < cj + 2; ++j)
        for (int i = ci; i < ci + 2; ++i) {
          const uint32_t base = uint32_t(out.vertices.size());
          vertex(i, j);
          vertex(i + 1, j);
          vertex(i + 1, j + 1);
          vertex(i, j + 1);
          out.indices.insert(out.indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
        }
    }
}

}  // namespace

double texture_repeat_m(Pattern pattern) {
  // Boards and rack sections are small, a floor's grain is coarse.
  switch (pattern) {
    case Pattern::kPlain: return 0;
    case Pattern::kWood: return 0.6;
    case Pattern::kSteel: return 0.5;
    case Pattern::kJoints: return 2.0;
    case Pattern::kStripes:
    case Pattern::kPaint: return 1.0;
  }
  return 0;
}

Eigen::Vector2f texture_uv(const Vector3d& p, const Vector3d& n, Pattern pattern) {
  const double size_m = texture_repeat_m(pattern);
  if (size_m == 0) return Eigen::Vector2f::Zero();
  const Vector3d a = n.cwiseAbs();
  // Along the grain: a board's length is x or y, so the first coordinate runs along it.
  const Eigen::Vector2d uv = a.z() >= a.x() && a.z() >= a.y() ? Eigen::Vector2d(p.x(), p.y())
                             : a.x() >= a.y()                 ? Eigen::Vector2d(p.y(), p.z())
                                                              : Eigen::Vector2d(p.x(), p.z());
  return (uv / size_m).cast<float>();
}

void Geometry::add_vertex(const Vector3d& p, const Vector3d& n, const Vector3f& colour, Pattern pattern) {
  Vertex v;
  for (int k = 0; k < 3; ++k) {
    v.position[k] = float(p[k]);
    v.normal[k] = float(n[k]);
    v.colour[k] = to_byte(colour[k]);
  }
  v.colour[3] = uint8_t(pattern);
  const Eigen::Vector2f uv = texture_uv(p, n, pattern);
  v.uv[0] = uv.x();
  v.uv[1] = uv.y();
  vertices.push_back(v);
  bounds.extend(p);
}

void Geometry::add_part(const MeshPart& part, const Eigen::Isometry3d& pose, Pattern pattern) {
  const size_t n = part.positions.size();
  if (n == 0 || part.triangles.size() < 3) return;
  // Normals as given; if a loader left them out, smooth ones from the faces.
  std::vector<Vector3d> normals(n, Vector3d::Zero());
  if (part.normals.size() == n) {
    for (size_t i = 0; i < n; ++i) normals[i] = part.normals[i].cast<double>();
  } else {
    for (size_t t = 0; t + 2 < part.triangles.size(); t += 3) {
      const uint32_t a = part.triangles[t], b = part.triangles[t + 1], c = part.triangles[t + 2];
      if (a >= n || b >= n || c >= n) continue;
      const Vector3d fn = (part.positions[b] - part.positions[a]).cross(part.positions[c] - part.positions[a]).cast<double>();
      normals[a] += fn;
      normals[b] += fn;
      normals[c] += fn;
    }
  }
  const uint32_t base = uint32_t(vertices.size());
  const Eigen::Matrix3d R = pose.linear();
  for (size_t i = 0; i < n; ++i) {
    Vector3d nw = R * normals[i];
    if (nw.squaredNorm() > 0) nw.normalize();
    add_vertex(pose * part.positions[i].cast<double>(), nw, part.colour, pattern);
  }
  // Each triangle wound counter-clockwise seen from the side its normals point to, so the
  // renderer can cull back faces whatever winding the file had.
  for (size_t t = 0; t + 2 < part.triangles.size(); t += 3) {
    const uint32_t a = part.triangles[t], b = part.triangles[t + 1], c = part.triangles[t + 2];
    if (a >= n || b >= n || c >= n) continue;  // a malformed triangle is dropped, not drawn
    const Eigen::Vector3f face = (part.positions[b] - part.positions[a]).cross(part.positions[c] - part.positions[a]);
    if (face.cast<double>().dot(normals[a] + normals[b] + normals[c]) < 0)
      indices.insert(indices.end(), {base + a, base + c, base + b});
    else
      indices.insert(indices.end(), {base + a, base + b, base + c});
  }
}

void Geometry::add_mesh(const Mesh& mesh, const Eigen::Isometry3d& pose, Pattern pattern) {
  for (const MeshPart& part : mesh.parts) add_part(part, pose, pattern);
}

void Geometry::add_box(const Eigen::AlignedBox3d& box, const Eigen::Isometry3d& pose, const Vector3f& colour,
                       Pattern pattern) {
  if (box.isEmpty()) return;
  const Vector3d c = box.center(), h = 0.5 * box.sizes();
  for (int axis = 0; axis < 3; ++axis)
    for (int sign : {1, -1}) {
      // u x v = the outward normal, so the corners below run counter-clockwise seen from outside.
      int u = (axis + 1) % 3, v = (axis + 2) % 3;
      if (sign < 0) std::swap(u, v);
      Vector3d n = Vector3d::Zero();
      n[axis] = sign;
      const uint32_t base = uint32_t(vertices.size());
      for (auto [su, sv] : {std::pair{-1, -1}, {1, -1}, {1, 1}, {-1, 1}}) {
        Vector3d p = c;
        p[axis] += sign * h[axis];
        p[u] += su * h[u];
        p[v] += sv * h[v];
        add_vertex(pose * p, pose.linear() * n, colour, pattern);
      }
      indices.insert(indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
    }
}

void Geometry::add_polygon(const std::vector<Vector2d>& polygon, double z, const Vector3f& colour, Pattern pattern) {
  const std::vector<uint32_t> tri = triangulate(polygon);
  if (tri.empty()) return;
  const uint32_t base = uint32_t(vertices.size());
  for (const Vector2d& p : polygon) add_vertex(Vector3d(p.x(), p.y(), z), Vector3d::UnitZ(), colour, pattern);
  for (uint32_t i : tri) indices.push_back(base + i);
}

std::vector<uint32_t> triangulate(const std::vector<Vector2d>& input) {
  std::vector<Vector2d> p = input;
  if (p.size() > 3 && (p.front() - p.back()).norm() < 1e-12) p.pop_back();  // closed outline
  if (p.size() < 3) return {};
  const double area = signed_area(p);
  if (!(std::abs(area) > 1e-12)) return {};
  std::vector<uint32_t> ring(p.size());
  for (size_t i = 0; i < p.size(); ++i) ring[i] = uint32_t(area > 0 ? i : p.size() - 1 - i);

  std::vector<uint32_t> out;
  while (ring.size() > 3) {
    const size_t m = ring.size();
    bool clipped = false;
    for (size_t i = 0; i < m && !clipped; ++i) {
      const uint32_t a = ring[(i + m - 1) % m], b = ring[i], c = ring[(i + 1) % m];
      if (cross(p[a], p[b], p[c]) <= 1e-12) continue;  // reflex or collinear: not an ear
      bool blocked = false;
      for (uint32_t k : ring) {
        if (k == a || k == b || k == c) continue;
        if (p[k] == p[a] || p[k] == p[b] || p[k] == p[c]) continue;
        if (in_triangle(p[k], p[a], p[b], p[c])) {
          blocked = true;
          break;
        }
      }
      if (blocked) continue;
      out.insert(out.end(), {a, b, c});
      ring.erase(ring.begin() + long(i));
      clipped = true;
    }
    if (!clipped) {
      // Only collinear runs or a self-touching outline are left: drop the flattest corner so
      // the loop always ends (a bad outline loses a sliver; it never hangs).
      size_t flattest = 0;
      double best = INFINITY;
      for (size_t i = 0; i < m; ++i) {
        const double c = std::abs(cross(p[ring[(i + m - 1) % m]], p[ring[i]], p[ring[(i + 1) % m]]));
        if (c < best) best = c, flattest = i;
      }
      ring.erase(ring.begin() + long(flattest));
    }
  }
  if (cross(p[ring[0]], p[ring[1]], p[ring[2]]) > 1e-12) out.insert(out.end(), {ring[0], ring[1], ring[2]});
  return out;
}

void add_floor(const Scene& scene, const Eigen::AlignedBox2d& area, Geometry& out) {
  if (area.isEmpty()) return;
  // Emitted top layer first and the slab last: llvmpipe tests depth before shading, so a
  // pixel under paint is shaded once, not once per layer.
  add_ramps(scene.ground, area, out);

  struct Paint {
    double z;
    std::vector<Vector2d> polygon;
    Vector3f colour;
    Pattern pattern;
  };
  std::vector<Paint> paint;
  auto strip = [&](const Vector2d& a, const Vector2d& b, double width, double z, const Vector3f& colour) {
    const Vector2d d = b - a;
    if (d.norm() < 1e-9) return;
    const Vector2d side = Vector2d(-d.y(), d.x()).normalized() * (0.5 * width);
    paint.push_back({z, {a - side, b - side, b + side, a + side}, colour, Pattern::kPaint});
  };

  // Zones tinted by kind, walkways striped; edge lines on aisles and walkways.
  for (const Zone& zone : scene.zones) {
    if (zone.polygon.size() < 3) continue;
    const double z = zone_height(zone.kind);
    paint.push_back({z, zone.polygon, zone_colour(zone.kind), zone.kind == "walkway" ? Pattern::kStripes : Pattern::kPaint});
    if (zone.kind != "aisle" && zone.kind != "walkway") continue;
    const Vector3f line = zone.kind == "aisle" ? kAisleLine : kWalkwayLine;
    for (size_t i = 0, j = zone.polygon.size() - 1; i < zone.polygon.size(); j = i++)
      strip(zone.polygon[j], zone.polygon[i], 0.10, z + kEdgeLineHeight, line);
  }

  // The marked route: its two edges as thin white lines.
  const Route& route = scene.route;
  if (route.width_m > 0)
    for (size_t i = 0; i + 1 < route.points.size(); ++i) {
      const Vector2d d = route.points[i + 1] - route.points[i];
      if (d.norm() < 1e-9) continue;
      const Vector2d side = Vector2d(-d.y(), d.x()).normalized() * (0.5 * route.width_m);
      for (double s : {-1.0, 1.0})
        strip(route.points[i] + s * side, route.points[i + 1] + s * side, 0.06, kRouteHeight, kRouteLine);
    }

  // The task's targets: a ring for each "reach", a line across each "pass" gate, the outline
  // of each floor area a pallet goes to. On a ramp they lie on its surface.
  auto task_line = [&](const Vector2d& a, const Vector2d& b) {
    double top = 0;
    for (const Vector2d& p : {a, b, Vector2d(0.5 * (a + b))}) top = std::max(top, scene.ground.height(p.x(), p.y()));
    strip(a, b, kTaskLineWidth, top > 1e-4 ? top + kRampLift + kTaskHeight : kTaskHeight, kTaskColour);
  };
  for (const TaskStep& step : scene.task.steps) {
    if (step.kind == "reach" && step.radius_m > 0) {
      for (int i = 0; i < kRingSegments; ++i) {
        const double a0 = 2 * M_PI * i / kRingSegments, a1 = 2 * M_PI * (i + 1) / kRingSegments;
        task_line(step.point + step.radius_m * Vector2d(std::cos(a0), std::sin(a0)),
                  step.point + step.radius_m * Vector2d(std::cos(a1), std::sin(a1)));
      }
    } else if (step.kind == "pass") {
      task_line(step.gate_a, step.gate_b);
    } else if (step.kind == "move" && step.to_object.empty() && !step.area.isEmpty()) {
      const Eigen::AlignedBox2d& r = step.area;
      const Vector2d c[4] = {r.min(), Vector2d(r.max().x(), r.min().y()), r.max(), Vector2d(r.min().x(), r.max().y())};
      for (int i = 0; i < 4; ++i) task_line(c[i], c[(i + 1) % 4]);
    }
  }

  std::stable_sort(paint.begin(), paint.end(), [](const Paint& a, const Paint& b) { return a.z > b.z; });
  for (const Paint& p : paint) out.add_polygon(p.polygon, p.z, p.colour, p.pattern);

  // The slab: its top is the ground plane z = 0.
  out.add_box(Eigen::AlignedBox3d(Vector3d(area.min().x(), area.min().y(), -0.2),
                                  Vector3d(area.max().x(), area.max().y(), 0.0)),
              Eigen::Isometry3d::Identity(), kFloorColour, Pattern::kJoints);
}

}  // namespace forklift::render
