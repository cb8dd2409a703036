// One SVG figure per manoeuvre, like the paper's figures 9-21.
#pragma once
#include <string>
#include "forklift/manoeuvre.h"

namespace forklift {
void write_manoeuvre_figure(const ManoeuvreResult& result, const std::string& description, const std::string& path);
}
