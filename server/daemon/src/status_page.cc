#include "status_page.h"

#include <algorithm>
#include <ctime>
#include <string>

#include "fleetmap/core/printable_text.h"

namespace fleetmap {
namespace {

constexpr std::int64_t kNsPerSecond = 1'000'000'000;

// Kept short and plain: the page must read well in a terminal browser and on a phone too.
constexpr const char* kStyle = R"css(
:root { color-scheme: light; }
body { font: 15px/1.45 system-ui, -apple-system, "Segoe UI", Roboto, "DejaVu Sans", sans-serif;
  margin: 0; background: #f4f6f8; color: #1d2733; }
header { background: #1f3a5f; color: #fff; padding: 18px 32px; }
header h1 { margin: 0; font-size: 24px; font-weight: 600; }
header p { margin: 4px 0 0; color: #c9d6e6; font-size: 13px; }
main { padding: 20px 32px 32px; }
h2 { font-size: 17px; margin: 26px 0 10px; }
.banner { background: #fff4d6; border: 1px solid #e8c66a; padding: 8px 12px; border-radius: 6px; }
.cards { display: flex; flex-wrap: wrap; gap: 12px; }
.card { background: #fff; border: 1px solid #dde3ea; border-radius: 8px; padding: 10px 16px;
  min-width: 150px; }
.card .label { font-size: 12px; color: #5b6b7c; text-transform: uppercase; letter-spacing: .04em; }
.card .value { font-size: 24px; font-weight: 600; font-variant-numeric: tabular-nums; }
.card .note { font-size: 12px; color: #5b6b7c; }
table { border-collapse: collapse; background: #fff; border: 1px solid #dde3ea; width: 100%; }
th, td { text-align: left; padding: 7px 12px; border-bottom: 1px solid #e7ebf0; }
th { background: #eef2f6; font-size: 13px; color: #3a4a5c; }
td.num, th.num { text-align: right; font-variant-numeric: tabular-nums; }
td.uuid { font-family: ui-monospace, "DejaVu Sans Mono", monospace; font-size: 13px; }
.ago { color: #5b6b7c; margin-left: 6px; }
.of { color: #5b6b7c; }
.never { color: #9a6b00; }
.late { color: #9a6b00; font-weight: bold; }
.differs { color: #fff; background: #b00020; font-weight: bold; }
dl.totals { display: grid; grid-template-columns: max-content auto; gap: 4px 24px; margin: 0;
  background: #fff; border: 1px solid #dde3ea; border-radius: 8px; padding: 12px 16px; }
dl.totals dt { color: #5b6b7c; }
dl.totals dd { margin: 0; font-variant-numeric: tabular-nums; }
.empty { color: #5b6b7c; font-style: italic; }
figure.map { margin: 0; background: #fff; border: 1px solid #dde3ea; border-radius: 8px;
  padding: 8px; }
figure.map img { display: block; max-width: 100%; max-height: 75vh; width: auto; height: auto; }
figure.map svg { display: block; width: 100%; height: 75vh; touch-action: none; cursor: grab; }
figure.map svg #nodes circle { cursor: pointer; }
.explorer-bar { display: flex; flex-wrap: wrap; gap: 8px 16px; align-items: center;
  margin-bottom: 8px; font-size: 14px; }
.explorer-bar a { color: #1f3a5f; }
.explorer-bar a.current { font-weight: 600; text-decoration: none; color: #1d2733; }
.explorer-bar button { font: inherit; min-width: 2.2em; padding: 2px 8px; }
.caption { font-size: 13px; color: #5b6b7c; margin: 4px 0 0; }
#node-details { background: #fff; border: 1px solid #dde3ea; border-radius: 8px;
  padding: 8px 12px; margin-top: 8px; font-size: 14px; }
#node-details dl { display: grid; grid-template-columns: max-content auto; gap: 2px 16px;
  margin: 0; }
#node-details dt { color: #5b6b7c; }
#node-details dd { margin: 0; font-family: ui-monospace, "DejaVu Sans Mono", monospace; }
)css";

// The explorer's script: the picture inline, zoom and pan by its viewBox, a node's facts on a
// click (set as text, never as markup), and the page's periodic reload until someone explores.
constexpr const char* kExplorerScript = R"js(
(function () {
  var explorer = document.getElementById('explorer');
  var figure = document.getElementById('map');
  if (!explorer || !figure || figure.tagName !== 'FIGURE') return;
  var base = explorer.dataset.kind === 'change' ? '/change' : '/map';
  var revision = explorer.dataset.revision;
  var details = document.getElementById('node-details');
  var svg = null, nodes = [], box = null, full = null, touched = false, drag = null;
  function show() { svg.setAttribute('viewBox', box.map(function (v) { return v.toFixed(2); }).join(' ')); }
  function zoom(factor, x, y) {
    box = [x - (x - box[0]) * factor, y - (y - box[1]) * factor, box[2] * factor, box[3] * factor];
    touched = true;
    show();
  }
  function centre() { return [box[0] + box[2] / 2, box[1] + box[3] / 2]; }
  function at(event) {
    var p = svg.createSVGPoint();
    p.x = event.clientX;
    p.y = event.clientY;
    return p.matrixTransform(svg.getScreenCTM().inverse());
  }
  function describe(i) {
    var n = nodes[i];
    if (!n) return;
    touched = true;
    var list = document.createElement('dl');
    [['node', n.id], ['robot', n.robot], ['outing', n.outing], ['captured', n.captured],
     ['time of day', n.time_of_day + ' UTC'],
     ['revision', n.revision === null ? 'unversioned' : 'r' + n.revision]].forEach(function (f) {
      var dt = document.createElement('dt'), dd = document.createElement('dd');
      dt.textContent = f[0];
      dd.textContent = f[1];
      dd.dataset.field = f[0];
      list.append(dt, dd);
    });
    details.replaceChildren(list);
    details.dataset.node = n.id;
  }
  function hook() {
    svg.addEventListener('wheel', function (event) {
      event.preventDefault();
      var p = at(event);
      zoom(event.deltaY < 0 ? 0.8 : 1.25, p.x, p.y);
    }, { passive: false });
    svg.addEventListener('pointerdown', function (event) {
      drag = { x: event.clientX, y: event.clientY, box: box.slice() };
    });
    window.addEventListener('pointerup', function () { drag = null; });
    svg.addEventListener('pointermove', function (event) {
      if (!drag || (event.clientX === drag.x && event.clientY === drag.y)) return;
      var m = svg.getScreenCTM();
      box = [drag.box[0] - (event.clientX - drag.x) / m.a, drag.box[1] - (event.clientY - drag.y) / m.d,
             box[2], box[3]];
      touched = true;
      show();
    });
    svg.querySelectorAll('#nodes circle').forEach(function (disc, i) {
      disc.addEventListener('click', function () { describe(i); });
    });
  }
  function fail(why) { details.textContent = 'The picture could not be loaded: ' + why; }
  function load(tries) {
    fetch(base + '.svg?r=' + revision).then(function (response) {
      if (response.status === 503 && tries < 120) {
        figure.textContent = 'The picture of revision ' + revision + ' is being drawn.';
        setTimeout(function () { load(tries + 1); }, 1000);
        return null;
      }
      if (!response.ok) throw new Error('HTTP ' + response.status);
      return response.text();
    }).then(function (text) {
      if (text === null) return null;
      var doc = new DOMParser().parseFromString(text, 'image/svg+xml');
      svg = document.importNode(doc.documentElement, true);
      svg.removeAttribute('width');
      svg.removeAttribute('height');
      full = svg.getAttribute('viewBox').split(' ').map(Number);
      box = full.slice();
      figure.replaceChildren(svg);
      hook();
      return fetch(base + '.json?r=' + revision).then(function (response) {
        if (!response.ok) throw new Error('HTTP ' + response.status);
        return response.json();
      }).then(function (facts) {
        nodes = facts;
        figure.dataset.ready = String(facts.length);
      });
    }).catch(function (error) { fail(error.message); });
  }
  document.getElementById('zoom-in').addEventListener('click', function () {
    if (svg) zoom(0.8, centre()[0], centre()[1]);
  });
  document.getElementById('zoom-out').addEventListener('click', function () {
    if (svg) zoom(1.25, centre()[0], centre()[1]);
  });
  document.getElementById('zoom-reset').addEventListener('click', function () {
    if (svg) { box = full.slice(); show(); }
  });
  setInterval(function () { if (!touched) location.reload(); }, 30000);
  load(0);
})();
)js";

void Card(std::string& html, std::string_view label, std::string_view value,
          std::string_view note = {}) {
  html += "<div class=\"card\"><div class=\"label\">";
  html += EscapeHtml(label);
  html += "</div><div class=\"value\">";
  html += EscapeHtml(value);
  html += "</div>";
  if (!note.empty()) {
    html += "<div class=\"note\">";
    html += EscapeHtml(note);
    html += "</div>";
  }
  html += "</div>\n";
}

void Total(std::string& html, std::string_view label, std::string_view value) {
  html += "<dt>";
  html += EscapeHtml(label);
  html += "</dt><dd>";
  html += EscapeHtml(value);
  html += "</dd>\n";
}

void LastSyncCell(std::string& html, std::int64_t last_sync_ns, std::int64_t now_ns) {
  if (last_sync_ns == 0) {
    html += "<td class=\"never\">never</td>";
    return;
  }
  const std::string iso = UtcIsoTime(last_sync_ns);
  html += "<td><time datetime=\"" + iso + "\">" + iso + "</time><span class=\"ago\">" +
          TimeAgo(last_sync_ns, now_ns) + "</span></td>";
}

// A robot's release cells: its channel, the revision it installed and how far
// that is from what the channel names, the last download sent, and a flag when its map is not
// the one it was sent. Each cell carries the value as data-* for scripts and tests.
void ReleaseCells(std::string& html, const RobotStatus& robot) {
  html += "<td class=\"channel\">" + EscapeHtml(robot.channel) + "</td>";
  html += "<td class=\"num installed\" data-revision=\"" +
          std::to_string(robot.installed_revision) + "\">" +
          (robot.installed_revision > 0 ? std::to_string(robot.installed_revision) : "none") +
          "</td>";
  if (robot.behind_known) {
    html += std::string("<td class=\"num behind") + (robot.behind != 0 ? " late" : "") +
            "\" data-behind=\"" + std::to_string(robot.behind) + "\">" +
            std::to_string(robot.behind) + "</td>";
  } else {
    html += "<td class=\"num behind\">-</td>";
  }
  html += "<td class=\"num sent\" data-revision=\"" + std::to_string(robot.sent_revision) + "\">" +
          (robot.sent_revision > 0 ? std::to_string(robot.sent_revision) : "none") + "</td>";
  html += robot.map_differs
              ? "<td class=\"flag differs\" title=\"the installed map's digest is not the one "
                "it was sent\">MAP DIFFERS</td>"
              : "<td class=\"flag\">ok</td>";
  if (robot.last_error.empty()) {
    html += "<td class=\"error none\">-</td>";
  } else {
    html += "<td class=\"error\"><time datetime=\"" + UtcIsoTime(robot.last_error_ns) + "\">" +
            UtcIsoTime(robot.last_error_ns) + "</time> " + EscapeHtml(robot.last_error) + "</td>";
  }
}

void RobotsTable(std::string& html, const FleetStatus& status) {
  html += "<h2>Robots (" + std::to_string(status.robots.size()) + ")</h2>\n";
  html +=
      "<table id=\"robots\">\n<thead><tr><th>Name</th><th>UUID</th><th>Last sync (UTC)</th>"
      "<th class=\"num\">Pushes</th><th class=\"num\">Downloads</th><th>Channel</th>"
      "<th class=\"num\">Installed</th><th class=\"num\">Behind</th><th class=\"num\">Sent</th>"
      "<th>Map</th><th>Last error</th></tr></thead>\n<tbody>\n";
  for (const RobotStatus& robot : status.robots) {
    html += "<tr data-robot=\"" + EscapeHtml(robot.uuid) + "\"><td>" + EscapeHtml(robot.name) +
            "</td><td class=\"uuid\">" + EscapeHtml(robot.uuid) + "</td>";
    LastSyncCell(html, robot.last_sync_ns, status.now_ns);
    html += "<td class=\"num\">" + std::to_string(robot.pushes) + "</td><td class=\"num\">" +
            std::to_string(robot.downloads) + "</td>";
    ReleaseCells(html, robot);
    html += "</tr>\n";
  }
  html += "</tbody>\n</table>\n";
  if (status.robots.empty()) {
    html += "<p class=\"empty\">No robots registered.</p>\n";
  }
  html += "<h2>Channels (" + std::to_string(status.channels.size()) + ")</h2>\n";
  if (status.channels.empty()) {
    html +=
        "<p class=\"empty\">No channel is set: every robot follows the head "
        "(<code>fleetmap channel set NAME REVISION</code> sets one).</p>\n";
    return;
  }
  html +=
      "<table id=\"channels\">\n<thead><tr><th>Channel</th><th class=\"num\">Revision</th>"
      "<th>Map</th></tr></thead>\n<tbody>\n";
  for (const auto& [name, revision] : status.channels) {
    html += "<tr><td>" + EscapeHtml(name) + "</td><td class=\"num\">" + std::to_string(revision) +
            "</td><td><a href=\"/?r=" + std::to_string(revision) + "\">its map</a></td></tr>\n";
  }
  html += "</tbody>\n</table>\n";
}

// The map explorer (status_page.h). The picture's address names its revision, so a browser
// fetches each revision's once and never shows an older one from its cache.
void MapExplorer(std::string& html, const FleetStatus& status, const PageView& view) {
  const bool head = view.kind == PictureKind::kMap && view.revision < 0;
  const std::int64_t shown = head ? status.picture_revision : view.revision;
  const std::string r = std::to_string(shown);
  const bool change = view.kind == PictureKind::kChange;
  html += "<h2>Map</h2>\n<section id=\"explorer\" data-kind=\"" +
          std::string(change ? "change" : "map") + "\" data-revision=\"" + r + "\">\n";
  // The views: the head, each channel's revision, and the change shown (if one is).
  html += "<nav class=\"explorer-bar\"><span>Show:</span>";
  const auto view_link = [&](const std::string& href, const std::string& label, bool current) {
    html += "<a href=\"" + href + "\"" + (current ? " class=\"current\"" : "") + ">" +
            EscapeHtml(label) + "</a>";
  };
  view_link("/", "head (r" + std::to_string(status.head_revision) + ")", head);
  for (const auto& [name, revision] : status.channels) {
    view_link("/?r=" + std::to_string(revision), name + " (r" + std::to_string(revision) + ")",
              !head && !change && revision == view.revision);
  }
  if (change) view_link("/?change=" + r, "what r" + r + " changed", true);
  if (!head && !change &&
      std::none_of(status.channels.begin(), status.channels.end(),
                   [&](const auto& c) { return c.second == view.revision; })) {
    view_link("/?r=" + r, "r" + r, true);
  }
  html +=
      "<span>Zoom:</span><button type=\"button\" id=\"zoom-in\" title=\"zoom in\">+</button>"
      "<button type=\"button\" id=\"zoom-out\" title=\"zoom out\">&minus;</button>"
      "<button type=\"button\" id=\"zoom-reset\" title=\"the whole map\">reset</button>"
      "</nav>\n";
  if (head && !status.head_picture_svg) {
    html += "<p class=\"empty\" id=\"map\">The picture of revision " +
            std::to_string(status.head_revision) + " is being drawn.</p>\n</section>\n";
    return;
  }
  const std::string file = change ? "/change.svg?r=" : "/map.svg?r=";
  const std::string alt =
      change ? "what revision " + r + " changed" : "the map at revision " + r + " seen from above";
  html += "<figure class=\"map\" id=\"map\"><img src=\"" + file + r + "\" alt=\"" + alt +
          "\"></figure>\n";
  html += "<p class=\"caption\">";
  if (change) {
    html += "What revision " + r +
            " changed: nodes it added orange, nodes it hid faded where they were, the rest "
            "grey; a blue square around each node that stands in for a node its merge omitted.";
  } else {
    html += "Revision " + r;
    if (head && status.picture_revision != status.head_revision) {
      html += " (revision " + std::to_string(status.head_revision) + " is being drawn)";
    }
    html +=
        ": each connected component in its own frame, nodes coloured by the UTC time of day "
        "they were captured, metric edges dark, path-memory edges faint.";
  }
  html +=
      " Wheel or buttons to zoom, drag to pan, click a node for its outing, robot, time of day "
      "and revision.</p>\n<div id=\"node-details\">No node chosen.</div>\n</section>\n";
}

// The latest revisions, newest first: who made each, when, and what it added and hid (a
// retirement hides, a revert of one adds back).
void HistoryTable(std::string& html, const FleetStatus& status) {
  html += "<h2>History (latest " + std::to_string(status.recent_revisions.size()) + " of " +
          std::to_string(status.head_revision) + ")</h2>\n";
  html +=
      "<table id=\"history\">\n<thead><tr><th class=\"num\">Revision</th><th>Kind</th>"
      "<th>Robot</th><th>Author</th><th>When (UTC)</th><th class=\"num\">Nodes added</th>"
      "<th class=\"num\">Nodes hidden</th><th>Picture</th></tr></thead>\n<tbody>\n";
  for (const RevisionRow& row : status.recent_revisions) {
    const std::string when = UtcIsoTime(row.created_ns);
    const std::string of =
        row.of.empty() ? "" : " <span class=\"of\">" + EscapeHtml(row.of) + "</span>";
    html += "<tr><td class=\"num\">" + std::to_string(row.revision) + "</td><td>" +
            EscapeHtml(row.kind) + of + "</td><td>" + EscapeHtml(row.robot) + "</td><td>" +
            EscapeHtml(row.author) + "</td><td><time datetime=\"" + when + "\">" + when +
            "</time><span class=\"ago\">" + TimeAgo(row.created_ns, status.now_ns) +
            "</span></td><td class=\"num\">" + std::to_string(row.nodes_added) +
            "</td><td class=\"num\">" + std::to_string(row.nodes_hidden) +
            "</td><td><a class=\"change\" href=\"/?change=" + std::to_string(row.revision) +
            "\">what it changed</a></td></tr>\n";
  }
  html += "</tbody>\n</table>\n";
  if (status.recent_revisions.empty()) {
    html += "<p class=\"empty\">No revisions yet.</p>\n";
  }
}

}  // namespace

std::string EscapeHtml(std::string_view raw) {
  // Controls and bidirectional overrides shown as escapes, then markup's own.
  std::string out;
  AppendMarkupEscaped(out, PrintableText(raw));
  return out;
}

std::string UtcIsoTime(std::int64_t utc_ns) {
  // Floor division, so a moment before 1970 still names the second it falls in.
  std::int64_t seconds = utc_ns / kNsPerSecond;
  if (utc_ns % kNsPerSecond < 0) --seconds;
  const std::time_t time = static_cast<std::time_t>(seconds);
  std::tm utc{};
  gmtime_r(&time, &utc);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &utc);
  return text;
}

std::string TimeAgo(std::int64_t then_ns, std::int64_t now_ns) {
  const std::int64_t minutes = then_ns >= now_ns ? 0 : (now_ns - then_ns) / (60 * kNsPerSecond);
  if (minutes < 120) return std::to_string(minutes) + " min ago";
  if (minutes < 48 * 60) return std::to_string(minutes / 60) + " h ago";
  return std::to_string(minutes / (24 * 60)) + " d ago";
}

std::string FleetStatusPage(const FleetStatus& status, const PageView& view) {
  std::string html;
  html.reserve(8192 + status.robots.size() * 256);
  html +=
      "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
      "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
      // A status page is left open on a screen: reload now and then (the script does, until
      // someone explores the map).
      "<noscript><meta http-equiv=\"refresh\" content=\"30\"></noscript>\n";
  html += "<title>fleetmapd — revision " + std::to_string(status.head_revision) + "</title>\n";
  html += "<style>";
  html += kStyle;
  html += "</style>\n</head>\n<body>\n<header><h1>fleetmapd</h1><p>";
  if (!status.listen.empty()) {
    html += "sync on " + EscapeHtml(status.listen) + (status.tls ? " (TLS)" : " (plain TCP)");
    html += " · ";
  }
  if (status.started_ns != 0) {
    html += "up since " + UtcIsoTime(status.started_ns) + " · ";
  }
  html += "snapshot " + UtcIsoTime(status.now_ns) + "</p></header>\n<main>\n";
  if (status.draining) {
    html += "<p class=\"banner\">Draining: the server is stopping and takes no new sessions.</p>\n";
  }

  html += "<section class=\"cards\" id=\"summary\">\n";
  Card(html, "Head revision", std::to_string(status.head_revision));
  Card(html, "Map nodes", std::to_string(status.map_nodes));
  Card(html, "Map edges", std::to_string(status.map_edges),
       std::to_string(status.map_paths) + " paths");
  Card(html, "Landmark bytes", BytesText(static_cast<std::uint64_t>(status.map_landmark_bytes)),
       std::to_string(status.map_landmark_bytes) + " bytes");
  Card(html, "Merge queue", std::to_string(status.queue_length),
       status.merging ? "merging " + status.merging->submission + " from " + status.merging->robot
                      : std::string("idle"));
  if (status.dream.scheduled) {
    // The nightly dream (--dream-at): its progress while it runs, else what the last one left.
    const DreamStatus& dream = status.dream;
    Card(html, "Nightly dream", dream.running ? std::string("running") : dream.at + " UTC",
         dream.running ? std::to_string(dream.steps_done) + " of " +
                             std::to_string(dream.steps_all) + " merges"
         : dream.last_result.empty() ? "next " + UtcIsoTime(dream.next_ns)
                                     : "last: " + dream.last_result);
  }
  Card(html, "Sessions open", std::to_string(status.sessions_open),
       std::to_string(status.sessions_total) + " since start");
  html += "</section>\n";

  MapExplorer(html, status, view);
  HistoryTable(html, status);
  RobotsTable(html, status);

  html += "<h2>Totals since start</h2>\n<dl class=\"totals\" id=\"totals\">\n";
  Total(html, "Pushes accepted", std::to_string(status.pushes));
  Total(html, "Downloads streamed", std::to_string(status.downloads));
  Total(html, "Instance", status.instance);
  Total(html, "Merges committed", std::to_string(status.merges));
  if (!status.recent_merges.empty()) {
    std::string runs;
    for (const MergeRun& run : status.recent_merges) {
      if (!runs.empty()) runs += ", ";
      runs += "r" + std::to_string(run.revision) + " (" + run.submission.substr(0, 8) + ")";
    }
    Total(html, "Merges run here (latest)", runs);
  }
  Total(html, "Merges failed", std::to_string(status.merges_failed));
  Total(html, "Bytes received", BytesText(status.bytes_received));
  Total(html, "Bytes sent", BytesText(status.bytes_sent));
  if (status.errors_by_code.empty()) {
    Total(html, "Errors sent", "none");
  } else {
    std::string errors;
    for (const auto& [code, count] : status.errors_by_code) {
      if (!errors.empty()) errors += ", ";
      errors += code + " × " + std::to_string(count);
    }
    Total(html, "Errors sent", errors);
  }
  html += "</dl>\n</main>\n<script>";
  html += kExplorerScript;
  html += "</script>\n</body>\n</html>\n";
  return html;
}

}  // namespace fleetmap
