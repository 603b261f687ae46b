// Writes one node with a fixed UUID into a new SQLite store through the installed fleetmap
// library, closes the store, reopens it read-only and reads the node back. Prints
// "round trip ok: ..." and exits 0 when what came back is what went in; anything else exits 1.
#include <cstdint>
#include <iostream>
#include <string>

#include "fleetmap/core/error.h"
#include "fleetmap/core/graph.h"
#include "fleetmap/core/uuid.h"
#include "fleetmap/store/graph_store.h"

namespace {

fleetmap::Landmarks TwoLandmarks() {
  fleetmap::Landmarks landmarks;
  landmarks.points_camera = {{1.0f, -0.5f, 4.0f}, {-2.0f, 0.25f, 7.5f}};
  fleetmap::Descriptor256 first{};
  fleetmap::Descriptor256 second{};
  for (std::size_t i = 0; i < first.size(); ++i) {
    first[i] = static_cast<std::uint8_t>(i);
    second[i] = static_cast<std::uint8_t>(255 - i);
  }
  landmarks.descriptors = {first, second};
  return landmarks;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: store_round_trip NEW_SQLITE_FILE\n";
    return 2;
  }
  const std::string uri = std::string("sqlite:") + argv[1];
  try {
    const fleetmap::Landmarks landmarks = TwoLandmarks();
    fleetmap::Node node;
    node.id = fleetmap::Uuid::Parse("01890a5d-ac96-7ab2-80e2-4536629c90de");
    node.stamp_ns = 1'700'000'000'123'456'789;
    node.robot = fleetmap::Uuid::Parse("01890a5d-ac96-7ab2-80e2-000000000001");
    node.outing = fleetmap::Uuid::Parse("01890a5d-ac96-7ab2-80e2-000000000002");
    node.landmarks_blob = fleetmap::EncodeLandmarks(landmarks);
    {
      auto writer = fleetmap::GraphStore::Open(uri);
      writer->PutNode(node);
    }  // closed here: the read below must come from the file

    fleetmap::StoreOptions read_only;
    read_only.read_only = true;
    auto reader = fleetmap::GraphStore::Open(uri, read_only);
    const fleetmap::Node read = reader->GetNode(node.id);
    const fleetmap::Landmarks read_landmarks = fleetmap::DecodeLandmarks(read.landmarks_blob);
    if (read != node || read_landmarks != landmarks) {
      std::cerr << "node read back differs from the node written: stamp_ns " << read.stamp_ns
                << ", " << read_landmarks.size() << " landmarks\n";
      return 1;
    }
    std::cout << "round trip ok: node " << read.id.ToString() << " stamp_ns " << read.stamp_ns
              << " landmarks " << read_landmarks.size() << " schema " << reader->schema_version()
              << "\n";
    return 0;
  } catch (const fleetmap::Error& e) {
    std::cerr << "fleetmap error: " << e.what() << "\n";
    return 1;
  }
}
