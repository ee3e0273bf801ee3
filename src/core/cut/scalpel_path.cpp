#include "tissue_cut/cut/scalpel_path.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

namespace tissue_cut {

namespace {

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r\n");
  if (b == std::string::npos) return "";
  const auto e = s.find_last_not_of(" \t\r\n");
  return s.substr(b, e - b + 1);
}

}  // namespace

ScalpelPath ScalpelPath::read(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw PathError(path + ": cannot open the path file");
  std::string line;
  int line_no = 0;
  std::vector<ToolPose> poses;
  bool header = false;
  while (std::getline(in, line)) {
    ++line_no;
    const std::string text = trim(line);
    if (text.empty() || text[0] == '#') continue;
    auto where = [&] { return path + ": line " + std::to_string(line_no) + ": "; };
    if (!header) {
      std::string compact;
      for (char c : text)
        if (c != ' ' && c != '\t') compact += c;
      if (compact != "t,x,y,z,qx,qy,qz,qw")
        throw PathError(where() + "expected the header t,x,y,z,qx,qy,qz,qw");
      header = true;
      continue;
    }
    std::stringstream row(text);
    std::string cell;
    double v[8];
    int n = 0;
    while (std::getline(row, cell, ',')) {
      if (n == 8) throw PathError(where() + "more than 8 columns");
      const std::string c = trim(cell);
      char* end = nullptr;
      v[n] = std::strtod(c.c_str(), &end);
      if (c.empty() || end != c.c_str() + c.size())
        throw PathError(where() + "column " + std::to_string(n + 1) + " is not a number");
      if (!std::isfinite(v[n]))
        throw PathError(where() + "column " + std::to_string(n + 1) + " is not finite");
      ++n;
    }
    if (n != 8) throw PathError(where() + "expected 8 columns, found " + std::to_string(n));
    ToolPose p;
    p.t = v[0];
    p.position = Vec3(v[1], v[2], v[3]);
    p.orientation = Eigen::Quaterniond(v[7], v[4], v[5], v[6]);
    if (p.orientation.norm() < 1e-9) throw PathError(where() + "the quaternion is zero");
    p.orientation.normalize();
    if (!poses.empty() && p.t < poses.back().t) throw PathError(where() + "time goes backwards");
    poses.push_back(p);
  }
  if (!header) throw PathError(path + ": empty path file (no header)");
  if (poses.empty()) throw PathError(path + ": the path has no poses");
  return ScalpelPath(std::move(poses));
}

ScalpelPath::ScalpelPath(std::vector<ToolPose> poses) : poses_(std::move(poses)) {
  if (poses_.empty()) throw PathError("a scalpel path needs at least one pose");
}

ToolPose ScalpelPath::at(double t) const {
  if (t <= poses_.front().t) return poses_.front();
  if (t >= poses_.back().t) return poses_.back();
  auto it = std::upper_bound(poses_.begin(), poses_.end(), t,
                             [](double x, const ToolPose& p) { return x < p.t; });
  const ToolPose& b = *it;
  const ToolPose& a = *(it - 1);
  const double span = b.t - a.t;
  const double s = span > 0 ? (t - a.t) / span : 1.0;
  ToolPose out;
  out.t = t;
  out.position = (1 - s) * a.position + s * b.position;
  out.orientation = a.orientation.slerp(s, b.orientation);
  return out;
}

}  // namespace tissue_cut
