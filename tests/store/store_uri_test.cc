// Opening stores by URI, and what a bad URI or a bad file gets back.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "fleetmap/core/error.h"
#include "fleetmap/store/graph_store.h"
#include "store_backends.h"

namespace fleetmap {
namespace {

ErrorCode CodeOfOpening(const std::string& uri) {
  try {
    GraphStore::Open(uri);
  } catch (const Error& e) {
    return e.code();
  }
  ADD_FAILURE() << "opened " << uri;
  return ErrorCode::kBackend;
}

TEST(StoreUri, UnknownSchemeIsInvalid) {
  EXPECT_EQ(CodeOfOpening("mysql://localhost/x"), ErrorCode::kInvalidArgument);
  EXPECT_EQ(CodeOfOpening("/tmp/map.sqlite"), ErrorCode::kInvalidArgument);
  EXPECT_EQ(CodeOfOpening("sqlite:"), ErrorCode::kInvalidArgument);
}

TEST(StoreUri, SqliteInMissingDirectoryIsABackendError) {
  EXPECT_EQ(CodeOfOpening("sqlite:/nonexistent-dir-fleetmap/x/map.sqlite"), ErrorCode::kBackend);
}

TEST(StoreUri, FileThatIsNotADatabaseIsCorruptAndUntouched) {
  testing::SqliteBackend dir;
  const std::string path = dir.Uri().substr(std::string("sqlite:").size());
  const std::string garbage(8192, 'G');
  std::ofstream(path, std::ios::binary) << garbage;
  EXPECT_EQ(CodeOfOpening("sqlite:" + path), ErrorCode::kCorrupt);
  std::ifstream in(path, std::ios::binary);
  const std::string after((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(after, garbage);  // refusing it did not write into it
}

TEST(StoreUri, SqliteDoubleSlashFormIsAccepted) {
  testing::SqliteBackend dir;
  const std::string path = dir.Uri().substr(std::string("sqlite:").size());
  auto store = GraphStore::Open("sqlite://" + path);
  EXPECT_EQ(store->uri(), "sqlite:" + path);
}

TEST(StoreUri, UnreachablePostgresIsABackendErrorWithoutPassword) {
  // Port 1 on loopback: nothing listens there, so the connection is refused at once.
  try {
    GraphStore::Open("postgresql://robot:s3cret@127.0.0.1:1/fleet?connect_timeout=2");
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kBackend);
    EXPECT_EQ(std::string(e.what()).find("s3cret"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace fleetmap
