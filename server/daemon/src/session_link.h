// What a connection's protocol handler (sync_protocol_handler.h) may ask of the connection under
// it, and nothing more: the handler decides what to answer, the session (sync_session.h) moves
// the bytes. Beast's advanced server keeps a session's I/O apart from the request handling the
// same way.
//
// Threading: every call on the session's strand (where the handler runs).
#pragma once

#include <boost/asio/any_io_executor.hpp>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "fleetmap/core/uuid.h"
#include "fleetmap/repository/repository.h"
#include "fleetmap/sync.pb.h"

namespace fleetmap::daemon {

// Frames written a batch at a time, each batch read on a store worker while the one before is
// being written (a download being encoded): at most two batches are alive, and a slow robot
// slows the reads instead of piling batches up in memory.
class FrameSource {
 public:
  virtual ~FrameSource() = default;
  // The next batch of framed bytes (each with its length prefix); empty once every frame was
  // given. On a store worker, one call at a time. Throws Error (the session then fails with
  // the handler's answer to it, once no write is in flight).
  virtual std::vector<std::string> NextBatch(Repository& repository) = 0;
  // On the strand: `frames`, `bytes` together, are written (the source may keep them).
  virtual void Written(std::vector<std::string>& frames, std::uint64_t bytes) = 0;
  // On the strand: every frame is written; the session reads the next frame after this.
  virtual void Finished() = 0;
};

class SessionLink {
 public:
  virtual ~SessionLink() = default;

  // Sends `frame`, then reads the next one (or closes when the server is shutting down).
  virtual void Reply(const v1::SyncFrame& frame) = 0;
  // Sends an ErrorFrame saying `code` and `text`, logs it, and closes.
  virtual void Fail(v1::ErrorFrame::Code code, const std::string& text) = 0;
  // The robot said bye: closes.
  virtual void CloseAfterBye() = 0;
  // A hello arrived whole: the connection may no longer be evicted (connection_admission.h).
  virtual void HelloArrived() = 0;
  // The hello was accepted for `robot` named `name`: the connection counts among the robot's
  // sessions (robot_allowance.h) and takes a robot's frames. False when the robot holds its
  // maximum of sessions: nothing changed, and the handler refuses the hello.
  virtual bool JoinRobot(const Uuid& robot, const std::string& name) = 0;
  // Writes `frames` (each with its prefix) in order, runs `written(bytes)`, then reads the next
  // frame. The frames are not copied: `frames` is kept until the last write ends.
  virtual void SendFrames(std::shared_ptr<const std::vector<std::string>> frames,
                          std::function<void(std::uint64_t bytes)> written) = 0;
  // Writes `first`, then `source`'s batches until it is done (FrameSource), then reads the next
  // frame.
  virtual void StreamFrames(std::vector<std::string> first,
                            std::shared_ptr<FrameSource> source) = 0;
  // Keeps the session alive while a store job holds it.
  virtual std::shared_ptr<void> KeepAlive() = 0;
  // The session's strand.
  virtual boost::asio::any_io_executor executor() const = 0;
  // "PEER" or "PEER (robot NAME)", for logs.
  virtual std::string Who() const = 0;
  // The server is shutting down: a wait in progress (a merge status) answers now.
  virtual bool shutting_down() const = 0;
};

}  // namespace fleetmap::daemon
