#include "cushion_markers.h"

#include <algorithm>
#include <cmath>

#include "die_cushion_ident/core/util/formatted.h"

namespace die_cushion_ident {

namespace {

visualization_msgs::Marker marker(int id, int type, const std::string& frame, const ros::Time& stamp) {
  visualization_msgs::Marker m;
  m.header.frame_id = frame;
  m.header.stamp = stamp;
  m.ns = "die_cushion";
  m.id = id;
  m.type = type;
  m.action = visualization_msgs::Marker::ADD;
  m.pose.orientation.w = 1.0;
  m.color.a = 1.0;
  return m;
}

std::string line(const IdentifiedParameter& p) {
  const double relative = p.value != 0.0 ? 100.0 * std::abs(p.std / p.value) : 0.0;
  return formatted(FMT_STRING("{} = {:.4g} {} (+/- {:.1f} %)\n"), p.name, p.value, p.unit, relative);
}

}  // namespace

visualization_msgs::MarkerArray cushionMarkers(const CylinderGeometry& geometry, const CushionView& view,
                                               const HydraulicEstimate& estimate, const std::string& frame,
                                               const ros::Time& stamp) {
  const double radius = std::sqrt(geometry.piston_area / M_PI);
  const double stroke = geometry.stroke_length;
  const double x = std::clamp(std::isfinite(view.position) ? view.position : 0.0, 0.0, stroke);
  visualization_msgs::MarkerArray array;

  auto wall = marker(0, visualization_msgs::Marker::CYLINDER, frame, stamp);
  wall.pose.position.z = -0.5 * stroke;
  wall.scale.x = wall.scale.y = 2.2 * radius;
  wall.scale.z = stroke + 0.02;
  wall.color.r = wall.color.g = wall.color.b = 0.6;
  wall.color.a = 0.15;
  array.markers.push_back(wall);

  // The pressurised chamber lies below the piston: from -x down to the bottom of the stroke.
  const double share = std::clamp(view.pressure / geometry.supply_pressure, 0.0, 1.0);
  auto oil = marker(1, visualization_msgs::Marker::CYLINDER, frame, stamp);
  const double column = std::max(stroke - x, 1e-3);
  oil.pose.position.z = -x - 0.5 * column;
  oil.scale.x = oil.scale.y = 2.0 * radius;
  oil.scale.z = column;
  oil.color.r = share;
  oil.color.g = 0.2;
  oil.color.b = 1.0 - share;
  oil.color.a = 1.0;
  array.markers.push_back(oil);

  auto piston = marker(2, visualization_msgs::Marker::CYLINDER, frame, stamp);
  piston.pose.position.z = -x + 0.01;
  piston.scale.x = piston.scale.y = 2.0 * radius;
  piston.scale.z = 0.02;
  piston.color.r = piston.color.g = piston.color.b = 0.85;
  array.markers.push_back(piston);

  auto text = marker(3, visualization_msgs::Marker::TEXT_VIEW_FACING, frame, stamp);
  text.pose.position.x = 2.0 * radius + 0.25;
  text.pose.position.z = -0.3 * stroke;
  text.scale.z = 0.025;
  text.color.r = text.color.g = text.color.b = 1.0;
  text.text =
      formatted(FMT_STRING("p = {:.1f} bar, x = {:.0f} mm, {}\nmodel error {:.2f} bar rms\n"),
                view.pressure * 1e-5, x * 1e3, strokePhaseName(view.phase), view.simulation_error * 1e-5);
  for (const auto& p : estimate.parameters) text.text += line(p);
  array.markers.push_back(text);
  return array;
}

}  // namespace die_cushion_ident
