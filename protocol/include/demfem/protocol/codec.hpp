// Codec of the demfem wire protocol: Request/Reply structs <-> multipart messages (byte frames).
// Needs no socket, so every rule below is testable on its own.
//
// Frame layout (docs/protocol.md has the per-operation table)
// - Frame 0: UTF-8 JSON object header {"v":1,"op":"<name>","seq":N, ...operation fields}.
//   Replies add the operation's scalar fields, or {"error":{"code":C,"message":"..."}}.
// - Frames 1..: raw little-endian arrays, float64 for coordinates/forces/rigid motion, int32 for
//   triangle node ids. The header states each array's length ("n" nodes, "triangles" counts), and a
//   frame whose byte size does not match is rejected.
// - Limits (kMax*): a header above kMaxHeaderBytes, a frame above kMaxFrameBytes, more than
//   kMaxFrames frames or non-finite floats are rejected.
//
// Errors: decode*() throw ProtocolError with code BadRequest (malformed, wrong type, truncated,
// oversized, unknown op) or VersionMismatch ("v" != kProtocolVersion); the message names the field.
// They never crash or read out of bounds on any input.
#pragma once

#include "demfem/protocol/messages.hpp"

#include <cstddef>
#include <string>
#include <vector>

namespace demfem::protocol {

using Frame = std::string;             // bytes
using Multipart = std::vector<Frame>;  // frame 0 = JSON header

inline constexpr std::size_t kMaxHeaderBytes = 64 * 1024;
inline constexpr std::size_t kMaxFrameBytes = 256u * 1024 * 1024;
inline constexpr std::size_t kMaxFrames = 1 + 1024;  // header + one triangle frame per geometry

Multipart encode(const Request& request);
Multipart encode(const Reply& reply);

Request decodeRequest(const Multipart& message);
Reply decodeReply(const Multipart& message);

// Best effort for an error reply to an undecodable request: the "seq" and "op" of frame 0 if they
// can be read, else 0 and "error". Never throws.
Reply errorReplyFor(const Multipart& request, WireError code, const std::string& message);

}  // namespace demfem::protocol
