// Mitsuba 3 XML scene loader (subset; see README for the table of what is supported).
#pragma once
#include <map>
#include <stdexcept>
#include <string>
#include <vector>
#include "core/scene_desc.h"

namespace lt {

// Every loader error names the file, the line, the element and the parameter.
struct SceneError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

// defines: `-D name=value` from the command line; they override <default> values in the file.
SceneDesc loadScene(const std::string& path, const std::map<std::string, std::string>& defines = {});

// The command line's "-D name=value" list as a map for loadScene. Throws std::invalid_argument
// ("-D expects name=value, got '...'").
std::map<std::string, std::string> parseDefines(const std::vector<std::string>& defs);

}  // namespace lt
