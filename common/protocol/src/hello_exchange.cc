#include "fleetmap/protocol/hello_exchange.h"

#include "fleetmap/protocol/protocol_error.h"

namespace fleetmap {

v1::SyncFrame HelloFrame(const HelloMessage& message) {
  v1::SyncFrame frame;
  v1::Hello& hello = *frame.mutable_hello();
  hello.set_protocol_version(message.protocol_version);
  hello.set_robot_id(message.robot.ToBytesString());
  hello.set_token(message.token);
  hello.set_agent(message.agent);
  if (message.installed) *hello.mutable_installed() = *message.installed;
  return frame;
}

HelloMessage ReadHello(const v1::Hello& hello) {
  if (hello.protocol_version() < kOldestSyncProtocolVersion ||
      hello.protocol_version() > kSyncProtocolVersion) {
    throw ProtocolError(v1::ErrorFrame::UNSUPPORTED_VERSION,
                        "protocol version " + std::to_string(hello.protocol_version()) +
                            ": this server speaks versions " +
                            std::to_string(kOldestSyncProtocolVersion) + " to " +
                            std::to_string(kSyncProtocolVersion));
  }
  if (hello.robot_id().size() != Uuid::kSize) {
    // The id's form, not whether it is registered: this says nothing a stranger may not know.
    throw ProtocolError(v1::ErrorFrame::INVALID, "hello: a robot id of " +
                                                     std::to_string(hello.robot_id().size()) +
                                                     " bytes: robot ids are 16 bytes (a UUID)");
  }
  HelloMessage message;
  message.protocol_version = hello.protocol_version();
  message.robot = Uuid::FromBytes(hello.robot_id());
  message.token = hello.token();
  message.agent = hello.agent();
  if (hello.has_installed()) message.installed = hello.installed();
  return message;
}

v1::SyncFrame WelcomeFrame(const WelcomeMessage& message) {
  v1::SyncFrame frame;
  v1::Welcome& welcome = *frame.mutable_welcome();
  welcome.set_protocol_version(message.protocol_version);
  welcome.set_head_revision(message.head_revision);
  welcome.set_robot_name(message.robot_name);
  welcome.set_max_frame_bytes(message.max_frame_bytes);
  welcome.set_max_submission_bytes(message.max_submission_bytes);
  return frame;
}

WelcomeMessage ReadWelcome(const v1::Welcome& welcome) {
  WelcomeMessage message;
  message.protocol_version = welcome.protocol_version();
  message.head_revision = welcome.head_revision();
  message.robot_name = welcome.robot_name();
  message.max_frame_bytes = welcome.max_frame_bytes();
  message.max_submission_bytes = welcome.max_submission_bytes();
  return message;
}

v1::SyncFrame ByeFrame() {
  v1::SyncFrame frame;
  frame.mutable_bye();
  return frame;
}

}  // namespace fleetmap
