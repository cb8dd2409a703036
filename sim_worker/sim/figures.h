// SVG figures of the paper's manoeuvres (section 11, figures 9-21): the quantities the paper
// plots for each group of manoeuvres, one manoeuvre alone or a group overlaid.
#pragma once
#include <string>
#include <vector>

#include "forklift/dynamics/manoeuvre.h"

namespace forklift {

// Manoeuvres the paper presents together, and the figures it shows them in.
struct FigureGroup {
  std::vector<int> manoeuvres;   // e.g. {1, 2, 3}
  int first_figure = 0;          // the paper's figure number(s): 9, or 12-16
  int last_figure = 0;
  std::string name;              // e.g. "starting manoeuvres"
};

// 1-3 (fig 9), 4-5 (fig 10), 10-12 (fig 11), 14-15 (figs 12-16), 17-18 (figs 17-21).
const std::vector<FigureGroup>& figure_groups();
// The group holding manoeuvre `number`, or nullptr.
const FigureGroup* figure_group_of(int number);
// "figure_09_manoeuvres_1-3.svg", "figure_12-16_manoeuvres_14-15.svg".
std::string figure_file_name(const FigureGroup& group);

// One manoeuvre: its group's panels, one curve per wheel where the quantity is per wheel.
void write_manoeuvre_figure(const TruckParams& truck, const ManoeuvreResult& result,
                            const std::string& description, const std::string& path);

// A group overlaid: one panel per quantity and wheel, one curve per manoeuvre (same colour
// and dash pattern for a manoeuvre in every panel). `results` and `descriptions` pair up;
// runs may hold different sample times (one that tipped over stops early). Throws
// std::invalid_argument if they are empty or of different sizes.
void write_group_figure(const TruckParams& truck, const FigureGroup& group,
                        const std::vector<const ManoeuvreResult*>& results,
                        const std::vector<std::string>& descriptions, const std::string& path);

}  // namespace forklift
