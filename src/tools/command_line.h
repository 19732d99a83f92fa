#pragma once

#include <sys/stat.h>

#include <cerrno>
#include <sstream>
#include <string>
#include <vector>

namespace die_cushion_ident {

/// "a,b,,c" -> {a, b, c}: the command-line form of effect lists.
inline std::vector<std::string> splitList(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream stream(text);
  std::string item;
  while (std::getline(stream, item, ',')) {
    if (!item.empty()) out.push_back(item);
  }
  return out;
}

/// Creates `path` and its missing parents (mkdir -p); true when it is a directory afterwards.
inline bool makeDirectory(const std::string& path) {
  std::string partial;
  std::stringstream parts(path);
  std::string part;
  if (!path.empty() && path[0] == '/') partial = "/";
  while (std::getline(parts, part, '/')) {
    if (part.empty()) continue;
    partial += part + "/";
    if (mkdir(partial.c_str(), 0755) != 0 && errno != EEXIST) return false;
  }
  struct stat info;
  return stat(path.c_str(), &info) == 0 && S_ISDIR(info.st_mode);
}

}  // namespace die_cushion_ident
