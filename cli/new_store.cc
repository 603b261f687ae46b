#include "new_store.h"

#include <filesystem>

#include "fleetmap/core/error.h"
#include "repository_arguments.h"

namespace fleetmap::cli {
namespace {

void RequireNoNodes(GraphStore& store, const std::string& uri, const std::string& option) {
  const StoreStats stats = store.Stats();
  if (stats.nodes > 0) {
    throw Error(ErrorCode::kConflict,
                option + " " + uri + " already holds a map (" + std::to_string(stats.nodes) +
                    " nodes); name a new store, so that maps are never mixed");
  }
}

}  // namespace

void RequireNewStore(const std::string& uri, const std::string& option) {
  const std::string path = SqlitePath(uri);
  if (!path.empty() && !std::filesystem::exists(path)) return;
  const std::unique_ptr<GraphStore> store = GraphStore::Open(uri);
  RequireNoNodes(*store, uri, option);
}

StoreStats WriteNewStore(const std::string& uri, const std::string& option, const GraphBatch& map) {
  const std::unique_ptr<GraphStore> store = GraphStore::Open(uri);
  RequireNoNodes(*store, uri, option);
  store->Put(map);
  return store->Stats();
}

}  // namespace fleetmap::cli
