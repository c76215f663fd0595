// Participant: ownership of a Cyclone DDS participant and topic creation by generated type.
#include "dds/participant.hpp"

#include <utility>

#include "dds/security/credentials.hpp"

namespace teamscan::dds {

Result<Participant> Participant::create(std::uint32_t domain_id, const char* pki_dir) {
  dds_qos_t* qos = dds_create_qos();
  if (pki_dir != nullptr) security::add_security_properties(qos, pki_dir);
  const dds_entity_t h = dds_create_participant(domain_id, qos, nullptr);
  dds_delete_qos(qos);
  if (h < 0) {
    return Error{pki_dir != nullptr ? "dds: cannot create the secured participant (Cyclone's log says why; check the "
                                      "credentials with teamscan pki check, and CYCLONEDDS_URI)"
                                    : "dds: cannot create participant (check CYCLONEDDS_URI)",
                 0, static_cast<long>(h)};
  }
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
