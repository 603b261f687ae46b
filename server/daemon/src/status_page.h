// The status page of fleetmapd (GET / on the status HTTP server): one self-contained HTML
// document (inline CSS and one small inline script, no external assets: it works on a depot
// network without internet) with the facts of a FleetStatus — a summary (revision, map size,
// merge queue, sessions), the robots in <table id="robots"> (a header row in <thead>, one row
// per robot in <tbody>: name, UUID, last sync as UTC ISO time and "N min ago", pushes,
// downloads) and the totals since start; above the robots, the map explorer and the latest
// revisions in <table id="history"> (revision, kind, robot, author, time, nodes added and
// hidden, a link to what it changed).
//
// The map explorer (<section id="explorer" data-kind="map|change" data-revision="R">) shows
// one picture at full width: the head's map by default, the map of revision R (/?r=R: a
// channel's, linked from the view list and the channels table), or what revision R changed
// (/?change=R, linked from each history row). Server-rendered, it is <figure id="map"> with
// <img src="/map.svg?r=R"> (or /change.svg); the script replaces the image with the SVG itself,
// zooms and pans it by its viewBox (wheel, drag, the + / − / reset buttons), and on a click on
// a node shows its outing, robot, time of day and revision (from /map.json or /change.json) in
// #node-details as text. Without the script the page reloads itself every 30 s as before; with
// it, only until someone zooms or clicks.
//
// Every string that comes from the fleet (robot names, UUIDs, error codes, addresses) is
// HTML-escaped. Relative times ("5 min ago") are taken against status.now_ns.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "fleetmap/daemon/fleet_status.h"

namespace fleetmap {

// Which picture the explorer shows: the head's map (revision < 0), the map of `revision`, or
// what `revision` changed.
struct PageView {
  PictureKind kind = PictureKind::kMap;
  std::int64_t revision = -1;
};

// The page for one snapshot. Pure: the same status and view give the same page.
std::string FleetStatusPage(const FleetStatus& status, const PageView& view = {});

// `text` as PrintableText shows it (controls, bidirectional overrides and bytes that are not
// UTF-8 as visible escapes), with &, <, >, " and ' replaced by character references: safe
// inside element content and inside a double- or single-quoted attribute value.
std::string EscapeHtml(std::string_view text);

// "2024-05-01T12:34:56Z" for UTC nanoseconds since the Unix epoch (truncated to the second).
std::string UtcIsoTime(std::int64_t utc_ns);

// How long before `now_ns` the moment `then_ns` was, for a person: "0 min ago" ... "119 min
// ago", then "N h ago" up to 47 h, then "N d ago". A `then_ns` after `now_ns` (clocks of two
// machines) reads "0 min ago".
std::string TimeAgo(std::int64_t then_ns, std::int64_t now_ns);

}  // namespace fleetmap
