// A download request's parameters through every form they travel in: JSON state, the wire, and
// the policy the server reads them as (the one place with the server's defaults).

#include "fleetmap/protocol/download_request.h"

#include <gtest/gtest.h>

#include "expect_error.h"
#include "fleetmap/map_management/download_policy.h"
#include "fleetmap/protocol/download_exchange.h"
#include "fleetmap/protocol/protocol_error.h"

namespace fleetmap {
namespace {

DownloadParams EveryField() {
  DownloadParams params;
  params.policy = "route+tod+cover";
  params.mission_start_min = 510.5;
  params.window_min = 45;
  params.best_percent = 30;
  params.budget_bytes = 123456;
  params.epoch_min = 20;
  params.include_nodes = {Uuid::Parse("00000000-0000-7000-8000-000000000001"),
                          Uuid::Parse("00000000-0000-7000-8000-000000000002")};
  params.channel = "stable";
  params.route_anchor = Uuid::Parse("00000000-0000-7000-8000-000000000003");
  params.route_xyz = {0, 0, 0, 10, 0, 0, 20, 5, 0};
  params.route_radius_m = 7.5;
  return params;
}

TEST(DownloadRequestTest, EveryFieldSurvivesTheStateAndTheWire) {
  const DownloadParams params = EveryField();
  EXPECT_EQ(DownloadParamsFromJson(DownloadParamsToJson(params)), params);
  const v1::DownloadRequest wire = DownloadRequestOf(params, 17);
  EXPECT_EQ(wire.base_revision(), 17);
  EXPECT_EQ(DownloadParamsOf(wire), params);
  const DownloadAsk ask = ReadDownloadRequest(wire);
  EXPECT_EQ(ask.params, params);
  EXPECT_EQ(ask.base_revision, 17);
}

TEST(DownloadRequestTest, EqualRequestsHaveOneCanonicalFormWhoeverWroteTheirBytes) {
  const DownloadParams params = EveryField();
  const v1::DownloadRequest plain = DownloadRequestOf(params, 17);
  // The same request from a newer robot: a field this server does not know (number 999,
  // varint 1) after the ones it does. Other bytes, the same request.
  std::string newer_bytes = plain.SerializeAsString() + std::string("\xb8\x3e\x01", 3);
  v1::DownloadRequest newer;
  ASSERT_TRUE(newer.ParseFromString(newer_bytes));
  ASSERT_NE(newer.SerializeAsString(), plain.SerializeAsString());
  EXPECT_EQ(ReadDownloadRequest(newer).canonical, ReadDownloadRequest(plain).canonical);
  EXPECT_EQ(DownloadAskOf(params, 17).canonical, ReadDownloadRequest(plain).canonical);
  // Another base, or another field, is another request.
  EXPECT_NE(DownloadAskOf(params, 16).canonical, DownloadAskOf(params, 17).canonical);
  DownloadParams wider = params;
  wider.window_min += 1;
  EXPECT_NE(DownloadAskOf(wider, 17).canonical, DownloadAskOf(params, 17).canonical);
}

TEST(DownloadRequestTest, AStateWrittenBeforeChannelsAndRoutesReadsAsTheHeadWithoutARoute) {
  nlohmann::json old = DownloadParamsToJson(DownloadParams{});
  for (const char* key : {"channel", "route_xyz", "route_radius_m"}) old.erase(key);
  const DownloadParams read = DownloadParamsFromJson(old);
  EXPECT_EQ(read.channel, "head");
  EXPECT_FALSE(read.has_route());
}

TEST(DownloadRequestTest, ARequestNamingNoChannelFollowsTheHead) {
  v1::DownloadRequest request;
  request.set_policy("copy");
  EXPECT_EQ(DownloadParamsOf(request).channel, "head");
}

TEST(DownloadRequestTest, MalformedWireFieldsAreRefusedNamingThem) {
  v1::DownloadRequest bad_id = DownloadRequestOf(DownloadParams{}, 0);
  bad_id.set_route_outing("short");
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { DownloadParamsOf(bad_id); },
      "route: a node or outing id of 5 bytes");
  v1::DownloadRequest partial = DownloadRequestOf(DownloadParams{}, 0);
  partial.add_route_xyz(1);
  partial.add_route_xyz(2);
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { DownloadParamsOf(partial); },
      "not a whole number of x y z positions");
  v1::DownloadRequest many = DownloadRequestOf(DownloadParams{}, 0);
  for (int i = 0; i < 3 * (kMaxRoutePositions + 1); ++i) many.add_route_xyz(0);
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { DownloadParamsOf(many); }, "over this server's");
  // The server's reading says which message it was.
  try {
    ReadDownloadRequest(partial);
    ADD_FAILURE() << "a partial route was read";
  } catch (const ProtocolError& error) {
    EXPECT_EQ(error.frame_code(), v1::ErrorFrame::INVALID);
    EXPECT_EQ(error.message().rfind("download_request: route:", 0), 0u) << error.message();
  }
}

// 0 (and nothing above it) leaves each policy its own default; the budget counts only for a
// policy that has one.
TEST(DownloadRequestTest, ZeroMeansThePolicysOwnDefault) {
  DownloadParams params;
  params.policy = "tod+paths";
  params.mission_start_min = 600;
  const DownloadPolicy defaults = ParseDownloadPolicy("tod+paths");
  const DownloadPolicy read = PolicyOfRequest(params);
  EXPECT_EQ(read.window_min, defaults.window_min);
  EXPECT_EQ(read.best_percent, defaults.best_percent);
  EXPECT_EQ(read.epoch_min, defaults.epoch_min);
  EXPECT_EQ(read.mission_start_min, 600);
  EXPECT_FALSE(read.budget_bytes.has_value());

  params.window_min = 30;
  params.best_percent = 10;
  params.epoch_min = 15;
  params.budget_bytes = 5000;  // no "budget" in the name: not a budget
  const DownloadPolicy given = PolicyOfRequest(params);
  EXPECT_EQ(given.window_min, 30);
  EXPECT_EQ(given.best_percent, 10);
  EXPECT_EQ(given.epoch_min, 15);
  EXPECT_FALSE(given.budget_bytes.has_value());

  params.policy = "tod+budget";
  EXPECT_EQ(PolicyOfRequest(params).budget_bytes, std::optional<std::int64_t>(5000));
  // The cover window's own default differs from tod's: 0 keeps each one's.
  params = DownloadParams{};
  params.policy = "tod+cover";
  EXPECT_EQ(PolicyOfRequest(params).window_min, ParseDownloadPolicy("tod+cover").window_min);
}

TEST(DownloadRequestTest, TheRouteAndTheChannelAreReadAndChecked) {
  DownloadParams params = EveryField();
  const DownloadPolicy policy = PolicyOfRequest(params);
  ASSERT_TRUE(policy.route.has_value());
  EXPECT_EQ(policy.route->anchor, params.route_anchor);
  ASSERT_EQ(policy.route->anchor_p_m.size(), 3u);
  EXPECT_EQ(policy.route->anchor_p_m[2].y(), 5);
  EXPECT_EQ(policy.route->radius_m, 7.5);
  EXPECT_EQ(policy.include, params.include_nodes);

  DownloadParams round;
  SetRequestRoute(round, *policy.route, 0);
  EXPECT_EQ(round.route_xyz, params.route_xyz);
  EXPECT_EQ(round.route_radius_m, 0);

  params.channel = "Not A Channel";
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { PolicyOfRequest(params); }, "");
  params = DownloadParams{};
  params.policy = "copy+nonsense";
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { PolicyOfRequest(params); }, "");
}

}  // namespace
}  // namespace fleetmap
