// Participant: ownership of a Cyclone DDS participant and topic creation by generated type.
#include "dds/participant.hpp"

#include <utility>

namespace teamscan::dds {

Result<Participant> Participant::create(std::uint32_t domain_id) {
  const dds_entity_t h = dds_create_participant(domain_id, nullptr, nullptr);
  if (h < 0) return Error{"dds: cannot create participant (check CYCLONEDDS_URI)", 0, static_cast<long>(h)};
  return Participant{h};
}

Participant::Participant(Participant&& other) noexcept : handle_{std::exchange(other.handle_, 0)} {}

Participant& Participant::operator=(Participant&& other) noexcept {
  if (this != &other) {
    reset();
    handle_ = std::exchange(other.handle_, 0);
  }
  return *this;
}

Participant::~Participant() { reset(); }

void Participant::reset() {
  if (handle_ > 0) (void)dds_delete(handle_);
  handle_ = 0;
}

Result<dds_entity_t> Participant::create_topic(const dds_topic_descriptor_t* descriptor, const char* name) const {
  if (handle_ <= 0) return Error{"dds: participant not created"};
  const dds_entity_t t = dds_create_topic(handle_, descriptor, name, nullptr, nullptr);
  if (t < 0) return Error{"dds: cannot create topic", 0, static_cast<long>(t)};
  return t;
}

}  // namespace teamscan::dds
