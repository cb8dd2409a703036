// A tool the server runs as a child process (forklift-render for stills, forklift-sim for
// replays): a crash or a hang there costs one answer, never the server.
#pragma once

#include <string>
#include <vector>

namespace forklift::server {

// Runs args[0] with `args`, its standard output into `out_file` and its standard error into
// `err_file`, killing it after `timeout_s`. Returns its exit status; throws std::runtime_error
// ("<what> took over N s", "fork failed") when it could not finish. `what` names the tool in
// messages.
int run_child(const std::vector<std::string>& args, const std::string& out_file, const std::string& err_file,
              double timeout_s, const std::string& what);

// What a failed child said: its error file's first 500 bytes.
std::string child_complaint(const std::string& err_file);

// The file's bytes ("" if it cannot be read).
std::string slurp_file(const std::string& path);

}  // namespace forklift::server
