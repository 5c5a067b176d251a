// Conversions between the coupling API's types and the protocol's wire types (internal to adapter).
#pragma once

#include "demfem/adapter/coupling_api.hpp"
#include "demfem/protocol/messages.hpp"

namespace demfem::adapter::wire {

// The wire error codes are the API's error codes: one table, checked here.
static_assert(static_cast<int>(ErrorCode::BadRequest) == static_cast<int>(protocol::WireError::BadRequest));
static_assert(static_cast<int>(ErrorCode::UnknownGeometry) == static_cast<int>(protocol::WireError::UnknownGeometry));
static_assert(static_cast<int>(ErrorCode::SizeMismatch) == static_cast<int>(protocol::WireError::SizeMismatch));
static_assert(static_cast<int>(ErrorCode::VersionMismatch) == static_cast<int>(protocol::WireError::VersionMismatch));
static_assert(static_cast<int>(ErrorCode::SimulationFailed) == static_cast<int>(protocol::WireError::SimulationFailed));
static_assert(static_cast<int>(ErrorCode::Timeout) == static_cast<int>(protocol::WireError::Timeout));
static_assert(static_cast<int>(ErrorCode::PeerGone) == static_cast<int>(protocol::WireError::PeerGone));
static_assert(static_cast<int>(ErrorCode::Unsupported) == static_cast<int>(protocol::WireError::Unsupported));
static_assert(static_cast<int>(ErrorCode::Internal) == static_cast<int>(protocol::WireError::Internal));
static_assert(static_cast<int>(ErrorCode::Busy) == static_cast<int>(protocol::WireError::Busy));
static_assert(static_cast<int>(ErrorCode::Busy) == protocol::kLastWireError);

inline ErrorCode toApi(protocol::WireError code) { return static_cast<ErrorCode>(code); }
inline protocol::WireError toWire(ErrorCode code) { return static_cast<protocol::WireError>(code); }

inline protocol::ForceMode toWire(ForceMode mode) {
  return mode == ForceMode::IntervalMean ? protocol::ForceMode::IntervalMean : protocol::ForceMode::Instantaneous;
}
inline ForceMode toApi(protocol::ForceMode mode) {
  return mode == protocol::ForceMode::IntervalMean ? ForceMode::IntervalMean : ForceMode::Instantaneous;
}

inline protocol::RigidMotionData toWire(const RigidMotion& m) { return {m.origin_m, m.velocity_m_s, m.t0_s}; }
inline RigidMotion toApi(const protocol::RigidMotionData& m) { return {m.origin_m, m.velocity_m_s, m.t0_s}; }

}  // namespace demfem::adapter::wire
