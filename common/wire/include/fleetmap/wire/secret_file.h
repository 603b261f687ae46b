// The secrets of a sync link kept in files (a robot's token, fleetmapd's TLS private key) must
// be readable by their owner only, as ssh requires of a private key: a token
// file others can read lets any user of the robot's computer sync as the robot.
#pragma once

#include <filesystem>
#include <string_view>

namespace fleetmap {

// Throws Error(kInvalidArgument) when the file at `path` (a link is followed) can be read or
// written by its group or by others, naming it as `what` (e.g. "--token-file") with its mode
// and the `chmod 600` that fixes it. A file that cannot be examined (it does not exist) passes:
// the reading that follows reports it.
void RequirePrivateSecretFile(const std::filesystem::path& path, std::string_view what);

}  // namespace fleetmap
