#include "fleetmap/core/graph_io.h"

namespace fleetmap {

// Out of line, so each interface's vtable has one home.
GraphReader::~GraphReader() = default;
GraphWriter::~GraphWriter() = default;

}  // namespace fleetmap
