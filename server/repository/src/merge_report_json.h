// A MERGE report as the JSON kept with its revision (Revision::report), for `fleetmap log`.
#pragma once

#include <string>

#include "fleetmap/map_management/merge.h"

namespace fleetmap {

std::string MergeReportJson(const MergeReport& report);

}  // namespace fleetmap
