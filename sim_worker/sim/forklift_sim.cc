// forklift-sim: the offline model tool. Every command prints one JSON object on stdout;
// errors go to stderr with exit status 2 (bad arguments or data) or 3 (numerical failure).
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "evaluate.h"
#include "trace.h"
#include "figures.h"
#include "forklift/dynamics/manoeuvre.h"
#include "forklift/scene/scene.h"
#include "forklift/dynamics/stability.h"
#include "forklift/dynamics/validation.h"
#include "forklift/units/decimals.h"
#include "forklift/units/units.h"

using namespace forklift;
using nlohmann::json;

namespace {

json fz_json(const std::array<double, kNumWheels>& fz) {
  json j;
  for (int w = 0; w < kNumWheels; ++w) j[wheel_name(w)] = std::isfinite(fz[w]) ? json(fz[w]) : json(nullptr);
  return j;
}

// {"below_0.05_m_s": s, "below_0.1_m_s": s}: brake onset until the speed is under each; null
// where the truck never got there or did not brake.
json stop_times_json(const ManoeuvreResult& r) {
  json j;
  for (const ManoeuvreResult::StopTime& stop : r.stop_times) {
    std::ostringstream key;
    key << "below_" << stop.below_m_s << "_m_s";
    j[key.str()] = stop.s ? json(*stop.s) : json(nullptr);
  }
  return j;
}

json result_json(const ManoeuvreResult& r) {
  return {
      {"manoeuvre", r.manoeuvre},
      {"integrator", integrator_name(r.options.kind)},
      {"rtol", r.options.kind == IntegratorKind::kRk4 ? json(nullptr) : json(r.options.rtol)},
      {"sim_time_s", r.sim_time_s},
      {"steps", r.stats.steps},
      {"rhs_evals", r.stats.rhs_evals},
      {"wall_s", r.wall_s},
      {"real_time_factor", r.wall_s > 0 ? json(r.sim_time_s / r.wall_s) : json(nullptr)},
      {"max_pitch_deg", r.max_pitch_deg},
      {"max_roll_deg", r.max_roll_deg},
      {"min_fz_N", fz_json(r.min_fz_N)},
      {"rear_wheel_lifted", r.rear_wheel_lifted},
      {"stop_time_s", stop_times_json(r)},
      {"final_pose", {{"x", r.final_pose.x()}, {"y", r.final_pose.y()}, {"yaw", r.final_pose.z() * kRad}}},
      {"tipped_over", r.tipped_over},
  };
}

// --load-mass 0: no load; any other is a request the scenario loader's rules check.
std::optional<Load> cli_load(const TruckParams& truck, double mass, double offset, double height) {
  if (mass == 0) return std::nullopt;
  const LoadRequest r{mass, height, offset};
  if (const auto problem = load_request_problem(r, FORKLIFT_DATA_DIR))
    throw std::invalid_argument("--load-mass, --load-height, --load-offset: " + *problem);
  return requested_load(r, truck);
}

// A number as typed: no trailing zeros ("10", "12.5").
std::string number_text(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

// A signed distance as a direction: "0.650 m behind" for -0.65 with ("forward", "behind").
std::string offset(double v_m, const char* plus, const char* minus) {
  const std::string t = fixed_decimals(std::abs(v_m), 3);
  return t + " m " + (t.find_first_not_of("0.") == std::string::npos ? plus : v_m < 0 ? minus : plus);
}

// A point of the truck from the ground below the middle of its front axle.
std::string point_words(const Eigen::Vector3d& p) {
  return offset(p.x(), "forward", "behind") + ", " + offset(p.y(), "to the left", "to the right") + ", " + fixed_decimals(p.z(), 3) + " m up";
}

// A wheel as a person names it: "front left", not the JSON's key "front_left".
std::string wheel_words(int w) {
  std::string name = wheel_name(w);
  std::replace(name.begin(), name.end(), '_', ' ');
  return name;
}

std::string wheel_loads_words(const std::array<double, kNumWheels>& fz) {
  std::string s;
  char buf[64];
  for (int w = 0; w < kNumWheels; ++w) {
    if (std::isfinite(fz[w])) std::snprintf(buf, sizeof buf, "%.0f N", fz[w]);
    else std::snprintf(buf, sizeof buf, "not known");
    s += (w ? ", " : "") + wheel_words(w) + " " + buf;
  }
  return s;
}

// A manoeuvre's run as a person reads it: what ran, how the truck moved, where it ended.
void print_manoeuvre_words(const ManoeuvreResult& r) {
  std::printf("manoeuvre %d: %.1f s of sim time with %s", r.manoeuvre, r.sim_time_s, integrator_name(r.options.kind));
  if (r.options.kind != IntegratorKind::kRk4) std::printf(" (relative tolerance %g)", r.options.rtol);
  std::printf(", %ld steps and %ld model evaluations in %s ms of wall time", static_cast<long>(r.stats.steps),
              static_cast<long>(r.stats.rhs_evals), fixed_decimals(r.wall_s * 1e3, 2).c_str());
  if (r.wall_s > 0) std::printf(" (%.0f times real time)", r.sim_time_s / r.wall_s);
  std::printf("\nmost pitch %s deg, most roll %s deg; least wheel loads: %s; the rear wheel %s\n", fixed_decimals(r.max_pitch_deg, 2).c_str(),
              fixed_decimals(r.max_roll_deg, 2).c_str(), wheel_loads_words(r.min_fz_N).c_str(), r.rear_wheel_lifted ? "lifted" : "stayed on the ground");
  for (const ManoeuvreResult::StopTime& stop : r.stop_times) {
    if (stop.s) std::printf("from the brake's onset, below %g m/s after %.2f s\n", stop.below_m_s, *stop.s);
    else std::printf("from the brake's onset, never below %g m/s (or no braking)\n", stop.below_m_s);
  }
  std::printf("ended at x %s m, y %s m, heading %s deg; %s\n", fixed_decimals(r.final_pose.x(), 2).c_str(), fixed_decimals(r.final_pose.y(), 2).c_str(),
              fixed_decimals(r.final_pose.z() * kRad, 1).c_str(), r.tipped_over ? "the truck tipped over (roll or pitch beyond 20 deg)" : "the truck stayed upright");
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"forklift-sim: the SIMUCEL forklift truck model, offline"};
  app.set_version_flag("--version", FORKLIFT_VERSION);
  app.option_defaults()->always_capture_default();  // --help shows each option's default
  app.require_subcommand(1);
  app.fallthrough();  // --truck before or after the command
  // The paper's manoeuvres run on the paper's truck, everything else on the training truck.
  const std::string paper_truck = std::string(FORKLIFT_DATA_DIR) + "/trucks/simucel_paper.json";
  const std::string training_truck = std::string(FORKLIFT_DATA_DIR) + "/trucks/linde_e16c.json";
  std::string truck_file;
  app.add_option("--truck", truck_file,
                 "truck data file (default: data/trucks/simucel_paper.json for manoeuvre, paper and script; "
                 "the scenario's truck for evaluate; data/trucks/linde_e16c.json otherwise)")
      ->check(CLI::ExistingFile);

  // manoeuvre N
  auto* man = app.add_subcommand("manoeuvre", "run one of the paper's manoeuvres (section 11) for 20 s");
  int number = 0;
  std::string integrator = "cvode", csv, plot;
  IntegratorOptions opts;
  man->add_option("N", number, "1, 2, 3, 4, 5, 10, 11, 12, 14, 15, 17 or 18")->required();
  man->add_option("--integrator", integrator, "cvode (BDF, default), dopri5 or rk4")
      ->check(CLI::IsMember({"cvode", "dopri5", "rk4"}));
  man->add_option("--rtol", opts.rtol, "relative tolerance of the variable-step integrators")
      ->check(CLI::Range(1e-14, 0.1));
  man->add_option("--csv", csv, "write the time series here");
  man->add_option("--plot", plot, "write an SVG figure here");
  bool as_json = false;  // each model command: JSON for scripts instead of words
  man->add_flag("--json", as_json, "print the results as JSON (for scripts) instead of words");

  // paper: every manoeuvre, a table, figures
  auto* paper = app.add_subcommand("paper", "run every manoeuvre, print a summary table, write figures and CSV");
  std::string out_dir = "out";
  paper->add_option("--out", out_dir, "directory for the figures and CSV files");
  paper->add_option("--integrator", integrator, "cvode, dopri5 or rk4")->check(CLI::IsMember({"cvode", "dopri5", "rk4"}));

  // script: a manoeuvre as a cab control script (and its scenario), for the real-time loop
  auto* scr = app.add_subcommand("script", "write a manoeuvre as a cab control script (CSV, 100 Hz) and its scenario JSON");
  std::string script_out, scenario_out;
  scr->add_option("N", number, "manoeuvre number")->required();
  scr->add_option("--out", script_out, "CSV file to write")->required();
  scr->add_option("--scenario-out", scenario_out, "scenario JSON to write (start at rest, the manoeuvre's load)");

  // static
  auto* stat = app.add_subcommand("static", "settle the truck at rest, on level ground or parked on a grade");
  double load_mass = 0, load_height = 0, load_offset = 0, grade = 0;
  stat->add_option("--grade", grade, "slope in percent, + rising ahead of the truck (parked on its brakes)")
      ->check(CLI::Range(-50.0, 50.0));
  stat->add_flag("--json", as_json, "print the results as JSON (for scripts) instead of words");
  for (auto* sub : {stat}) {
    sub->add_option("--load-mass", load_mass, "load on the forks, kg (a 1 m cube at the rated load centre)");
    sub->add_option("--load-height", load_height, "height of the load's CoG above the floor, m");
    sub->add_option("--load-offset", load_offset, "lateral offset of the load, m (+ left)");
  }

  // tilt
  auto* tilt = app.add_subcommand("tilt", "virtual tilt-table test: the table angle at which a wheel leaves the ground");
  std::string axis = "longitudinal";
  bool iso = false;
  tilt->add_flag("--iso", iso, "the four tests of ISO 22915-2, each with its load, fork height, mast tilt and operator");
  tilt->add_option("--axis", axis, "longitudinal (front down) or lateral (right side down)")
      ->check(CLI::IsMember({"longitudinal", "lateral"}));
  tilt->add_option("--load-mass", load_mass, "load on the forks, kg");
  tilt->add_option("--load-height", load_height, "height of the load's CoG above the floor, m");
  tilt->add_flag("--json", as_json, "print the results as JSON (for scripts) instead of words");

  // validate: every closed-form and ISO check on a truck file
  auto* val = app.add_subcommand("validate", "run every closed-form and ISO 22915 check on a truck file: a table, or JSON");
  bool val_json = false;
  val->add_flag("--json", val_json, "print JSON instead of the table");
  std::string val_references = std::string(FORKLIFT_DATA_DIR) + "/validation/counterbalance_1600kg.json";
  val->add_option("--references", val_references,
                  "the numbers from outside the truck file (data sheet, tyre data) that the checks measure against, each with its source");

  // meshes: the warehouse's meshes (data/meshes/ holds this output) and, with --truck, the
  // truck's as its file builds them (an export: the truck's meshes are built at load time)
  auto* meshes = app.add_subcommand(
      "meshes", "write every shipped warehouse mesh (OBJ + MTL, built from boxes) into a directory; with --truck, "
                "the truck's meshes built from that file as well");
  std::string meshes_out;
  meshes->add_option("--out", meshes_out, "directory to write (created if missing)")->required();
  meshes->add_flag("--json", as_json, "print the files written as JSON (for scripts) instead of words");

  // evaluate: a scripted session offline, its events and mark (evaluate.cc)
  EvaluateOptions evaluate_options;
  auto* evaluate = add_evaluate_command(app, evaluate_options);
  // trace: a logged session re-simulated and sampled, for the debrief's replay (trace.cc)
  TraceOptions trace_options;
  auto* trace = add_trace_command(app, trace_options);

  // A value that must be given has no default to show ("N INT REQUIRED", not "N INT=0 REQUIRED").
  for (CLI::App* command : app.get_subcommands({}))
    for (CLI::Option* o : command->get_options())
      if (o->get_required()) o->default_str("");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;  // --help and --version: 0; bad usage: 2, as every program
  }

  if (*trace) return trace_main(trace_options, FORKLIFT_DATA_DIR);
  if (*evaluate) {
    evaluate_options.truck = truck_file;
    return evaluate_main(evaluate_options, FORKLIFT_DATA_DIR);
  }

  if (*meshes) {
    try {
      std::filesystem::create_directories(meshes_out);
      json files = json::array();
      for (const std::string& f : write_meshes(meshes_out)) files.push_back(f);
      if (!truck_file.empty())
        for (const std::string& f : write_truck_meshes(truck_file, meshes_out)) files.push_back(f);
      if (as_json) {
        std::cout << json{{"out", meshes_out}, {"meshes", files}}.dump(2) << std::endl;
      } else {
        std::string names;
        for (const json& f : files) names += (names.empty() ? "" : ", ") + f.get<std::string>();
        std::printf("%zu meshes written to %s: %s\n", files.size(), meshes_out.c_str(), names.c_str());
      }
      return 0;
    } catch (const std::exception& e) {
      std::cerr << "forklift-sim: " << e.what() << '\n';
      return 2;
    }
  }

  try {
    if (truck_file.empty()) truck_file = (*man || *paper || *scr) ? paper_truck : training_truck;
    const TruckParams truck = load_truck(truck_file);
    opts.kind = parse_integrator(integrator);

    if (*val) {
      const std::vector<ValidationCheck> checks = validate_truck(truck, load_validation_references(val_references));
      const long failed = std::count_if(checks.begin(), checks.end(), [](const ValidationCheck& c) { return !c.pass; });
      if (val_json) {
        json list = json::array();
        for (const ValidationCheck& c : checks)
          list.push_back({{"check", c.name}, {"measured", c.measured}, {"unit", c.unit}, {"required", c.required},
                          {"source", c.source}, {"pass", c.pass}});
        std::cout << json{{"truck", truck.name}, {"file", truck_file}, {"checks", list}, {"failed", failed}}.dump(2) << std::endl;
      } else {
        std::printf("%s (%s)\n", truck.name.c_str(), truck_file.c_str());
        std::printf("%-4s  %-100s  %12s %-9s  %s\n", "pass", "check", "measured", "", "required");
        for (const ValidationCheck& c : checks)
          std::printf("%-4s  %-100s  %12.3f %-9s  %s\n%4s  %-100s\n", c.pass ? "yes" : "NO", c.name.c_str(), c.measured,
                      c.unit.c_str(), c.required.c_str(), "", ("source: " + c.source).c_str());
        std::printf("%zu checks, %ld failed\n", checks.size(), failed);
      }
      return failed == 0 ? 0 : 3;
    }

    if (*man) {
      const ManoeuvreSpec spec = manoeuvre(number, truck);  // validates N before running
      // The model is evaluated at each sample only for a series that is written.
      const Sampling sampling = csv.empty() && plot.empty() ? Sampling::kMetrics : Sampling::kSeries;
      const ManoeuvreResult r = run_manoeuvre(truck, number, opts, 0.002, sampling);
      if (!csv.empty()) write_csv(r, csv);
      if (!plot.empty()) write_manoeuvre_figure(truck, r, spec.description, plot);
      if (as_json) std::cout << result_json(r).dump(2) << std::endl;
      else print_manoeuvre_words(r);
      return 0;
    }
    if (*scr) {
      const ManoeuvreSpec spec = manoeuvre(number, truck);
      std::ofstream f(script_out);
      if (!f) throw std::runtime_error("cannot write " + script_out);
      f << "# manoeuvre " << number << ": " << spec.description << "\n";
      f << "t,steer,accelerator,brake,lift,tilt,shift\n";
      f.precision(9);
      for (int k = 0; k * 0.01 <= spec.duration_s + 1e-9; ++k) {
        const double t = k * 0.01;
        const DriverInputs u = spec.inputs(t);
        f << t << ',' << u.steer_rad << ',' << u.drive_torque_N_m / truck.drive.drive_torque_max_N_m << ','
          << u.brake_torque_N_m / truck.drive.brake_torque_max_N_m << ",0,0,0\n";
      }
      if (!scenario_out.empty()) {
        const std::string data_dir = std::string(FORKLIFT_DATA_DIR) + "/";
        const std::string truck_ref =
            truck_file.rfind(data_dir, 0) == 0 ? truck_file.substr(data_dir.size()) : std::filesystem::absolute(truck_file).string();
        json sc = {{"truck", truck_ref}, {"start", {{"x_m", 0}, {"y_m", 0}, {"yaw_deg", 0}}},
                   {"manoeuvre", number}, {"load", nullptr}, {"duration_s", spec.duration_s}};
        if (spec.load)
          sc["load"] = {{"mass_kg", spec.load->mass_kg}, {"lateral_m", spec.load->cog_m.y()},
                        {"cog_height_m", 2.0}};
        std::ofstream(scenario_out) << sc.dump(2) << '\n';
      }
      return 0;
    }
    if (*paper) {
      std::filesystem::create_directories(out_dir);
      json all = json::array();
      // The columns in words and units: a person reads this table (summary.json is for scripts).
      std::printf("%-4s %-8s %7s %8s %9s %9s %9s %12s %11s %9s %9s %7s %6s\n", "no.", "method", "steps", "evals",
                  "wall ms", "pitch deg", "roll deg", "least rear N", "rear lifted", "stop 0.05", "stop 0.1", "yaw deg",
                  "tipped");
      // A run is kept only until the figure overlaying its group is written: each holds ~10k samples.
      std::map<int, std::pair<ManoeuvreResult, std::string>> done;
      std::vector<std::string> figure_files;
      for (int n : manoeuvre_numbers()) {
        const ManoeuvreSpec spec = manoeuvre(n, truck);
        const ManoeuvreResult& r = done[n].first = run_manoeuvre(truck, n, opts);
        done[n].second = spec.description;
        const std::string base = out_dir + "/manoeuvre_" + std::to_string(n);
        write_csv(r, base + ".csv", 5);
        write_manoeuvre_figure(truck, r, spec.description, base + ".svg");
        auto stop = [](const std::optional<double>& t) { return t ? std::to_string(*t).substr(0, 5) : std::string("-"); };
        std::printf("%-4d %-8s %7ld %8ld %9.1f %9.3f %9.3f %12.0f %11s %9s %9s %7s %6s\n", n, integrator_name(opts.kind),
                    r.stats.steps, r.stats.rhs_evals, r.wall_s * 1e3, r.max_pitch_deg, r.max_roll_deg,
                    r.min_fz_N[kRear], r.rear_wheel_lifted ? "yes" : "no", stop(r.stop_times[0].s).c_str(),
                    stop(r.stop_times[1].s).c_str(), fixed_decimals(r.final_pose.z() * kRad, 1).c_str(), r.tipped_over ? "yes" : "no");
        all.push_back(result_json(r));

        const FigureGroup* group = figure_group_of(n);
        if (!group) {
          done.erase(n);
          continue;
        }
        if (!std::all_of(group->manoeuvres.begin(), group->manoeuvres.end(), [&](int m) { return done.count(m); }))
          continue;
        std::vector<const ManoeuvreResult*> runs;
        std::vector<std::string> descriptions;
        for (int m : group->manoeuvres) runs.push_back(&done[m].first), descriptions.push_back(done[m].second);
        figure_files.push_back(figure_file_name(*group));
        write_group_figure(truck, *group, runs, descriptions, out_dir + "/" + figure_files.back());
        for (int m : group->manoeuvres) done.erase(m);
      }
      std::ofstream(out_dir + "/summary.json") << all.dump(2) << '\n';
      std::string names;
      for (const std::string& f : figure_files) names += (names.empty() ? "" : ", ") + f;
      std::printf("(pitch and roll: the most over the run; evals: of the model; stop 0.05 and 0.1: seconds from the brake's "
                  "onset until below 0.05 and 0.1 m/s; yaw: at the end)\n");
      std::printf("figures, CSV and summary.json written to %s/ (the paper's figures: %s)\n", out_dir.c_str(),
                  names.c_str());
      return 0;
    }
    if (*stat) {
      const std::optional<Load> load = cli_load(truck, load_mass, load_offset, load_height);
      const double lift = load ? std::max(0.0, lift_for_load_height(truck, *load, load_height)) : 0.0;
      const StaticReport s = static_report(truck, load, lift, grade);
      json contacts, j;
      for (int w = 0; w < kNumWheels; ++w) contacts[wheel_name(w)] = {s.wheel_contact_m[w].x(), s.wheel_contact_m[w].y()};
      j = {{"settled", s.settled},
           {"grade_pct", grade},
           {"drift_m", s.drift_m},
           {"total_mass_kg", s.total_mass_kg},
           {"cog_m", {s.cog_m.x(), s.cog_m.y(), s.cog_m.z()}},
           {"load_cog_m", s.load_cog_m ? json{s.load_cog_m->x(), s.load_cog_m->y(), s.load_cog_m->z()} : json(nullptr)},
           {"fork_lift_m", lift},
           {"wheel_contact_m", contacts},
           {"fz_N", fz_json(s.fz_N)},
           {"rear_wheel_lifted", s.rear_wheel_lifted}};
      if (as_json) {
        std::cout << j.dump(2) << std::endl;
      } else {
        std::printf("%s %s, %s (moved %.1f mm)\n", s.settled ? "at rest" : "NOT at rest",
                    grade == 0 ? "on level ground" : ("on a " + number_text(grade) + " % grade").c_str(),
                    grade == 0 ? "brakes off" : "its brakes applied", s.drift_m * 1e3);
        std::printf("mass %.0f kg; centre of gravity %s (from the ground below the middle of the front axle)\n", s.total_mass_kg,
                    point_words(s.cog_m).c_str());
        if (s.load_cog_m)
          std::printf("the load's centre of gravity %s; forks lifted %.3f m\n", point_words(*s.load_cog_m).c_str(), lift);
        else
          std::printf("no load\n");
        std::printf("wheel loads: %s; the rear wheel %s\n", wheel_loads_words(s.fz_N).c_str(),
                    s.rear_wheel_lifted ? "lifted" : "on the ground");
      }
      if (!s.settled) {
        std::cerr << "forklift-sim static: the truck does not come to rest"
                  << (grade != 0 ? " on this grade with its brakes applied" : " with every wheel on the ground") << '\n';
        return 3;
      }
      return 0;
    }
    if (*tilt && iso) {
      json list = json::array();
      bool all = true;
      const std::vector<IsoTiltTest> tests = iso_22915_2(truck);
      for (const IsoTiltTest& t : tests) {
        list.push_back({{"test", t.number}, {"name", t.name}, {"axis", t.axis == TiltAxis::kLateral ? "lateral" : "longitudinal"},
                        {"load_kg", t.load_kg}, {"fork_height_m", t.fork_height_m}, {"mast_tilt_deg", t.mast_tilt_rad * kRad},
                        {"required_slope_pct", t.required_slope_pct}, {"required_deg", t.required_deg},
                        {"critical_angle_deg", t.result.critical_angle_deg}, {"rigid_angle_deg", t.result.rigid_angle_deg},
                        {"margin_deg", t.margin_deg}, {"lifted_wheel", wheel_name(t.result.lifted_wheel)}, {"pass", t.pass}});
        all = all && t.pass;
      }
      if (as_json) {
        std::cout << json{{"standard", "ISO 22915-2"}, {"operator_kg", 98}, {"tests", list}, {"pass", all}}.dump(2) << std::endl;
        return 0;
      }
      std::printf("ISO 22915-2 tilt-table tests, with a 98 kg operator: %s\n", all ? "all passed" : "NOT all passed");
      for (const IsoTiltTest& t : tests)
        std::printf("test %d, %s (%s, %.0f kg at %.2f m, mast tilted %.1f deg): a wheel lifts at %.2f deg (rigid truck %.2f deg), "
                    "the %s first; %.2f deg required (%.1f %% slope), margin %.2f deg: %s\n",
                    t.number, t.name.c_str(), t.axis == TiltAxis::kLateral ? "sideways" : "lengthways", t.load_kg, t.fork_height_m,
                    t.mast_tilt_rad * kRad, t.result.critical_angle_deg, t.result.rigid_angle_deg,
                    wheel_words(t.result.lifted_wheel).c_str(), t.required_deg, t.required_slope_pct, t.margin_deg,
                    t.pass ? "passed" : "NOT passed");
      return 0;
    }
    if (*tilt) {
      const std::optional<Load> load = cli_load(truck, load_mass, 0, load_height);
      const double lift = load ? std::max(0.0, lift_for_load_height(truck, *load, load_height)) : 0.0;
      const TiltResult t = tilt_table(truck, load, lift, axis == "lateral" ? TiltAxis::kLateral : TiltAxis::kLongitudinal);
      if (as_json)
        std::cout << json{{"axis", axis}, {"load_mass_kg", load_mass}, {"critical_angle_deg", t.critical_angle_deg},
                          {"rigid_angle_deg", t.rigid_angle_deg}, {"lifted_wheel", wheel_name(t.lifted_wheel)}}.dump(2)
                  << std::endl;
      else
        std::printf("tilted %s with %s: a wheel lifts at %.2f deg (rigid truck %.2f deg), the %s first\n",
                    axis == "lateral" ? "sideways (right side down)" : "lengthways (front down)",
                    load_mass > 0 ? (number_text(load_mass) + " kg on the forks").c_str() : "no load", t.critical_angle_deg,
                    t.rigid_angle_deg, wheel_words(t.lifted_wheel).c_str());
      return 0;
    }
  } catch (const IntegratorError& e) {
    std::cerr << "forklift-sim: numerical failure: " << e.what() << '\n';
    return 3;
  } catch (const std::exception& e) {
    std::cerr << "forklift-sim: " << e.what() << '\n';
    return 2;
  }
  return 0;
}
