// `fleetmap render`: a picture of the map at a revision, or of what a range of revisions changed,
// seen from above: its layout, relaxed or composed (fleetmap/relaxation/relaxed_layout.h), drawn
// by the map picture (map_picture.h) as SVG text or, through OpenCV, as PNG pixels: the same
// picture either way.
#include <algorithm>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <utility>

#include "commands.h"
#include "fleetmap/core/error.h"
#include "fleetmap/interchange/map_picture.h"
#include "fleetmap/interchange/svg_canvas.h"
#include "fleetmap/raster/png_canvas.h"
#include "fleetmap/repository/revision_picture.h"
#include "repository_arguments.h"
#include "staged_output_file.h"

namespace fleetmap::cli {
namespace {

enum class PictureFormat { kPng, kSvg };

// The format --out's extension names (either case).
PictureFormat FormatOf(const std::string& out) {
  std::string extension = std::filesystem::path(out).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (extension == ".png") return PictureFormat::kPng;
  if (extension == ".svg") return PictureFormat::kSvg;
  throw Error(ErrorCode::kInvalidArgument,
              "unknown extension of --out '" + out + "'" +
                  (extension.empty() ? std::string(" (none)") : " ('" + extension + "')") +
                  ": expected .png or .svg");
}

NodeColouring ParseColouring(const std::string& text) {
  if (text == "time-of-day") return NodeColouring::kTimeOfDay;
  if (text == "revision") return NodeColouring::kRevision;
  throw Error(ErrorCode::kInvalidArgument,
              "unknown --colour '" + text + "': expected time-of-day or revision");
}

struct RenderArgs {
  std::string store;
  std::optional<RevisionNumber> revision;
  std::optional<std::string> diff;  // present: draw a change; empty text: --revision's own
  std::string out;
  std::string colour = "time-of-day";
  std::string layout = "relaxed";
};

RevisionNumber ParseRevisionText(const std::string& text, const std::string& diff) {
  std::size_t used = 0;
  long long value = -1;
  try {
    value = std::stoll(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (text.empty() || used != text.size() || value < 0 || !std::isdigit(text[0])) {
    throw Error(ErrorCode::kInvalidArgument,
                "--diff '" + diff + "': expected A..B (what the revisions after A up to B " +
                    "changed) or R (what revision R changed)");
  }
  return static_cast<RevisionNumber>(value);
}

// The range --diff names: "A..B", "R" (R-1..R), or nothing (--revision's, by default the head's).
std::pair<RevisionNumber, RevisionNumber> DiffRange(const RenderArgs& args,
                                                    Repository& repository) {
  const std::string& text = *args.diff;
  if (!text.empty() && args.revision) {
    throw Error(
        ErrorCode::kInvalidArgument,
        "--diff '" + text + "' names its revisions: give --revision only with a bare --diff");
  }
  std::pair<RevisionNumber, RevisionNumber> range;
  if (const std::size_t dots = text.find(".."); dots != std::string::npos) {
    range = {ParseRevisionText(text.substr(0, dots), text),
             ParseRevisionText(text.substr(dots + 2), text)};
  } else {
    const RevisionNumber to =
        text.empty() ? args.revision.value_or(repository.Head()) : ParseRevisionText(text, text);
    range = {to - 1, to};
  }
  RequireRevision(repository, range.second);
  if (range.first < 0 || range.first >= range.second) {
    throw Error(ErrorCode::kInvalidArgument,
                "--diff r" + std::to_string(range.first) + "..r" + std::to_string(range.second) +
                    ": a change is drawn from an earlier revision to a later one (the store's "
                    "first revision is 1)");
  }
  return range;
}

void RunRender(const RenderArgs& args) {
  const PictureFormat format = FormatOf(args.out);
  const NodeColouring colouring = ParseColouring(args.colour);
  const LayoutKind layout = ParseLayoutKind(args.layout);
  const std::unique_ptr<Repository> repository = OpenExistingRepository(args.store);
  std::optional<std::pair<RevisionNumber, RevisionNumber>> range;
  if (args.diff) range = DiffRange(args, *repository);
  const RevisionNumber revision =
      range ? range->second : args.revision.value_or(repository->Head());
  RequireRevision(*repository, revision);
  const std::string where =
      (range ? "r" + std::to_string(range->first) + "..r" + std::to_string(range->second)
             : "revision " + std::to_string(revision)) +
      " of " + repository->uri();
  // Opened before the map is read, so an --out that cannot be written fails at once.
  StagedOutputFile file(args.out);
  RelaxationReport relaxation;
  RevisionDiff diff;
  const MapPicture picture =
      range ? ComposeRevisionDiffPicture(*repository, range->first, range->second, where, layout,
                                         &relaxation, &diff)
            : ComposeRevisionPicture(*repository, revision, colouring, where, layout, &relaxation);
  if (!relaxation.failure.empty()) {
    std::fprintf(stderr, "fleetmap: warning: the relaxation failed (%s); the layout is composed\n",
                 relaxation.failure.c_str());
  }
  // A picture of nothing is almost always the wrong store or revision: say so rather than
  // write a file that looks like a success. (fleetmapd's status page does draw the empty
  // picture: a new server has no map yet, and its page must show something.)
  if (picture.empty()) {
    throw Error(ErrorCode::kNotFound, where + " holds no nodes: there is nothing to render");
  }
  if (format == PictureFormat::kSvg) {
    SvgCanvas canvas("fleetmap: " + where);
    picture.Draw(canvas);
    file.stream() << canvas.svg();
  } else {
    PngCanvas canvas;
    picture.Draw(canvas);
    file.stream() << canvas.EncodePng();
  }
  file.Commit();
  std::printf("rendered %s into %s\n", where.c_str(), args.out.c_str());
  std::printf(
      "  %s, %s; %d x %d px, scale bar %g m (%.3g px/m)\n",
      Count(static_cast<std::int64_t>(picture.node_positions().size()), "node").c_str(),
      Count(static_cast<std::int64_t>(picture.component_boxes().size()), "component").c_str(),
      picture.width_px(), picture.height_px(), picture.scale_bar_m(), picture.pixels_per_metre());
  if (range) {
    std::printf(
        "  changes: %zu nodes added, %zu hidden, %zu unchanged; %zu omitted nodes stood "
        "in for by %zu nodes\n",
        diff.added, diff.hidden, diff.unchanged, diff.omitted, diff.stand_ins);
  }
  if (layout == LayoutKind::kRelaxed && relaxation.failure.empty()) {
    std::printf(
        "  layout relaxed: %zu nodes over %zu metric edges (%zu between outings) in %d "
        "iterations, %.2f s\n",
        relaxation.nodes, relaxation.edges, relaxation.edges_between_outings, relaxation.iterations,
        relaxation.seconds);
  } else {
    std::printf("  layout composed\n");
  }
}

}  // namespace

void AddRenderCommand(CLI::App& app) {
  auto args = std::make_shared<RenderArgs>();
  CLI::App* command =
      app.add_subcommand("render", "Draw the map at a revision from above, as PNG or SVG");
  command->footer(
      "The picture: the map's layout (as `fleetmap export` uses: each connected component of "
      "the graph over metric edges in its own frame, the camera frame of its earliest node; "
      "--layout relaxed (default) places nodes by a pose-graph relaxation of the metric edges, "
      "so a loop closes where the robots drove it, --layout composed by composing the edges "
      "breadth first, so a loop's drift shows where it closes) seen from above, x to the right and "
      "z "
      "up the picture (camera frames: x right, y down, z forward, so for a camera looking "
      "ahead x/z is the ground). Components sit side by side in their own boxes; where one box "
      "lies beside another means nothing, since nothing measured joins them. One scale for "
      "all; the scale bar shows a round length in metres.\n"
      "Colours:\n"
      "  time-of-day  (default) each node's disc by the UTC time of day it was captured, on a "
      "colour wheel that closes at midnight: 00:00 blue, 04:00 magenta, 08:00 red, 12:00 "
      "yellow, 16:00 green, 20:00 cyan.\n"
      "  revision     each node by the revision that added it, from dark violet (the earliest "
      "shown) through blue and green to yellow (the latest).\n"
      "  --diff       (instead of --colour) what a range of revisions changed: nodes the "
      "range added orange, nodes it hid faded where they were, the rest grey; a blue square "
      "around each node that stands in for a node the range's merges omitted (seed 004 "
      "§V-A). --diff A..B is what the revisions after A up to B changed, --diff R what "
      "revision R changed (R-1..R), a bare --diff what --revision (default: the head) "
      "changed. The counts are printed and in the legend: a merge's are its report's "
      "(`fleetmap log`).\n"
      "  Dark lines are metric edges (a measured pose); faint grey lines are path-memory edges "
      "(a path's order, no pose) where no metric edge joins the same nodes. The legend under "
      "the map repeats this.\n"
      "--out FILE's extension chooses the format: .png (pixels, OpenCV) or .svg (text; one "
      "<circle> per node in <g id=\"nodes\">). The file is written as FILE.tmp and renamed "
      "over FILE when complete: a render that fails leaves no FILE (and an existing FILE as "
      "it was); a symbolic link at FILE.tmp is refused, never written through. A revision "
      "without nodes is refused (there is nothing to draw).");
  AddStoreOption(*command, args->store);
  command->add_option("--revision", args->revision, "Revision (default: the head)");
  command
      ->add_option("--diff", args->diff,
                   "Draw what changed: A..B, R (R-1..R), or bare for --revision's own change")
      ->expected(0, 1);
  command->add_option("--out", args->out, "The picture to write: FILE.png or FILE.svg")->required();
  command->add_option("--colour", args->colour, "Node colours: time-of-day or revision")
      ->capture_default_str();
  command->add_option("--layout", args->layout, "Node places: relaxed or composed")
      ->capture_default_str();
  command->callback([args] { RunRender(*args); });
}

}  // namespace fleetmap::cli
