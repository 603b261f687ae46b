#include "fleetmap/world/world_runs.h"

#include <algorithm>

#include "fleetmap/core/error.h"

namespace fleetmap {
namespace {

// Outings that train the appearance vocabulary: four drives in different light and weather,
// rendered apart from the scheduled outings so no held-out frame shapes the vocabulary.
std::vector<Outing> VocabularyOutings(const WorldConfig& config) {
  std::vector<Outing> outings;
  const double times[] = {3.0, 9.0, 15.0, 19.0};
  const Weather weathers[] = {Weather::kSun, Weather::kOvercast, Weather::kRain, Weather::kSun};
  for (int i = 0; i < 4; ++i) {
    Uuid::Bytes bytes{};
    for (int b = 0; b < 8; ++b)
      bytes[static_cast<std::size_t>(b)] = static_cast<std::uint8_t>(config.seed >> (8 * b));
    bytes[8] = 0xB0;
    bytes[15] = static_cast<std::uint8_t>(i + 1);
    Outing outing;
    outing.id = Uuid(bytes);
    outing.robot = outing.id;
    outing.day = i * 3;
    outing.start_time_h = times[i];
    outing.weather = weathers[i];
    outing.length_m = std::min(200.0, config.route.length_m);
    outings.push_back(outing);
  }
  return outings;
}

}  // namespace

std::shared_ptr<const AppearanceVocabulary> TrainWorldVocabulary(const World& world,
                                                                 const VocabularyOptions& options) {
  std::vector<Descriptor256> sample;
  for (const Outing& outing : VocabularyOutings(world.config())) {
    const std::vector<Frame> frames = world.Frames(outing);
    for (std::size_t i = 0; i < frames.size(); i += 4) {
      const auto& d = frames[i].landmarks.descriptors;
      sample.insert(sample.end(), d.begin(), d.end());
    }
  }
  if (sample.empty()) {
    throw Error(ErrorCode::kInvalidArgument, "world vocabulary: the world shows no landmarks");
  }
  return std::make_shared<const AppearanceVocabulary>(AppearanceVocabulary::Train(sample, options));
}

OutingStart DepotStart(const Outing& outing, const ExperienceMap& map) {
  OutingStart start;
  start.robot = outing.robot;
  start.outing = outing.id;
  if (map.size() == 0 || outing.start_arc_length_m != 0.0) return start;
  ExperienceMap::NodeIndex earliest = 0;
  for (ExperienceMap::NodeIndex i = 1; i < map.size(); ++i) {
    const Node& node = map.at(i).node;
    const Node& best = map.at(earliest).node;
    if (std::pair(node.stamp_ns, node.id) < std::pair(best.stamp_ns, best.id)) earliest = i;
  }
  start.start_node = map.at(earliest).node.id;
  return start;
}

}  // namespace fleetmap
