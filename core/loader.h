// Mitsuba 3 XML scene loader (subset; see README for the table of what is supported).
#pragma once
#include <map>
#include <stdexcept>
#include <string>
#include "core/scene_desc.h"

namespace lt {

// Every loader error names the file, the line, the element and the parameter.
struct SceneError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

// defines: `-D name=value` from the command line; they override <default> values in the file.
SceneDesc loadScene(const std::string& path, const std::map<std::string, std::string>& defines = {});

}  // namespace lt
