// The Prometheus metrics of fleetmapd (GET /metrics on the status HTTP server): every fact of a
// FleetStatus as metric families named fleetmap_*, in the text exposition format 0.0.4
// (prometheus_text.h).
//
// Label conventions: a robot's samples carry robot="name" and robot_id="uuid"; error codes
// appear as code="bad_token", the sync.proto name lowercased (Prometheus label values are
// conventionally lowercase snake case).
#pragma once

#include <string>

#include "fleetmap/daemon/fleet_status.h"

namespace fleetmap {

// The exposition text for one snapshot. Pure: the same status gives the same text.
std::string FleetMetricsText(const FleetStatus& status);

}  // namespace fleetmap
