// AppearanceVocabulary::Encode / Decode (fleetmap.v1.AppearanceVocabulary).
#include <cstring>
#include <string>

#include "fleetmap/core/error.h"
#include "fleetmap/ebn/appearance_index.h"
#include "fleetmap/vocabulary.pb.h"

namespace fleetmap {

std::string AppearanceVocabulary::Encode() const {
  v1::AppearanceVocabulary proto;
  proto.set_branching(options_.branching);
  proto.set_depth(options_.depth);
  proto.set_kmajority_iterations(options_.kmajority_iterations);
  proto.set_seed(options_.seed);
  proto.set_word_count(word_count_);
  std::string centres;
  centres.reserve(centres_.size() * sizeof(Descriptor256));
  for (std::size_t i = 0; i < nodes_.size(); ++i) {
    v1::VocabularyTreeNode* node = proto.add_nodes();
    node->set_first_child(nodes_[i].first_child);
    node->set_child_count(nodes_[i].child_count);
    node->set_word(nodes_[i].word);
    centres.append(reinterpret_cast<const char*>(centres_[i].data()), sizeof(Descriptor256));
  }
  proto.set_centres(std::move(centres));
  return proto.SerializeAsString();
}

AppearanceVocabulary AppearanceVocabulary::Decode(std::string_view bytes) {
  const auto corrupt = [](const std::string& what) {
    return Error(ErrorCode::kCorrupt, "appearance vocabulary: " + what);
  };
  v1::AppearanceVocabulary proto;
  if (!proto.ParseFromArray(bytes.data(), static_cast<int>(bytes.size()))) {
    throw corrupt("the bytes do not parse");
  }
  const auto count = static_cast<std::size_t>(proto.nodes_size());
  if (count == 0) throw corrupt("no tree nodes");
  if (proto.centres().size() != count * sizeof(Descriptor256)) {
    throw corrupt("centres hold " + std::to_string(proto.centres().size()) + " bytes for " +
                  std::to_string(count) + " nodes");
  }
  AppearanceVocabulary vocabulary;
  vocabulary.options_ = {proto.branching(), proto.depth(), proto.kmajority_iterations(),
                         proto.seed()};
  vocabulary.word_count_ = proto.word_count();
  std::vector<bool> word_seen(static_cast<std::size_t>(std::max(0, proto.word_count())), false);
  vocabulary.nodes_.resize(count);
  vocabulary.centres_.resize(count);
  for (std::size_t i = 0; i < count; ++i) {
    const v1::VocabularyTreeNode& node = proto.nodes(static_cast<int>(i));
    TreeNode& tree = vocabulary.nodes_[i];
    tree = {node.first_child(), node.child_count(), node.word()};
    const std::string where = "node " + std::to_string(i);
    if (tree.child_count < 0) throw corrupt(where + " has a negative child count");
    if (tree.child_count > 0) {
      // Children always come after their parent, so the tree has no cycle and descent ends.
      if (tree.first_child <= static_cast<int>(i) ||
          static_cast<std::size_t>(tree.first_child) + static_cast<std::size_t>(tree.child_count) >
              count) {
        throw corrupt(where + " has children out of range");
      }
    } else {
      if (tree.word < 0 || tree.word >= vocabulary.word_count_) {
        throw corrupt(where + " is a leaf without a word in [0, " +
                      std::to_string(vocabulary.word_count_) + ")");
      }
      word_seen[static_cast<std::size_t>(tree.word)] = true;
    }
    std::memcpy(vocabulary.centres_[i].data(), proto.centres().data() + i * sizeof(Descriptor256),
                sizeof(Descriptor256));
  }
  for (std::size_t w = 0; w < word_seen.size(); ++w) {
    if (!word_seen[w]) throw corrupt("word " + std::to_string(w) + " belongs to no leaf");
  }
  if (vocabulary.word_count_ < 1) throw corrupt("no words");
  return vocabulary;
}

}  // namespace fleetmap
