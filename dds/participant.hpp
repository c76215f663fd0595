// A DDS participant that deletes itself (and with it every reader, writer and waitset it made), and
// the teamscan topics created on it by type (dds/topics.hpp). Used by the robot's bridge and the
// ground station alike; allocates only when entities are created (start-up).
#pragma once

#include <cstdint>

#include <dds/dds.h>

#include "common/result.hpp"
#include "dds/topics.hpp"

namespace teamscan::dds {

// DDS_DOMAIN_DEFAULT: the domain from CYCLONEDDS_URI, or 0.
inline constexpr std::uint32_t kDefaultDomain = 0xFFFFFFFFu;

class Participant {
 public:
  // pki_dir: a DDS Security credential bundle (dds/security/credentials.hpp), checked by the caller
  // (check_credentials_for); the participant then authenticates, is access-controlled and encrypts as the
  // bundle's signed governance says. Null: an unsecured participant.
  [[nodiscard]] static Result<Participant> create(std::uint32_t domain_id, const char* pki_dir = nullptr);

  Participant() = default;  // holds nothing
  Participant(Participant&& other) noexcept;
  Participant& operator=(Participant&& other) noexcept;
  Participant(const Participant&) = delete;
  Participant& operator=(const Participant&) = delete;
  // Deleting the participant deletes its entities; with autodispose (the default) a writer's
  // instances are disposed, so readers see a clean stop rather than a lost writer (DDS_SYSTEMD.md 3.2).
  ~Participant();

  [[nodiscard]] dds_entity_t handle() const { return handle_; }
  [[nodiscard]] bool valid() const { return handle_ > 0; }
  void reset();  // deletes the participant now

  // The topic of Sample (TopicOf<Sample>), created once per participant (Cyclone returns the same
  // topic for the same name and type).
  template <class Sample>
  [[nodiscard]] Result<dds_entity_t> topic(const char* name = TopicOf<Sample>::name) const {
    return create_topic(TopicOf<Sample>::descriptor(), name);
  }

 private:
  explicit Participant(dds_entity_t handle) : handle_{handle} {}
  [[nodiscard]] Result<dds_entity_t> create_topic(const dds_topic_descriptor_t* descriptor, const char* name) const;
  dds_entity_t handle_ = 0;
};

// A reader or writer of Sample's topic with `qos` (not deleted here; the caller keeps it).
template <class Sample>
[[nodiscard]] Result<dds_entity_t> create_reader(const Participant& p, const dds_qos_t* qos,
                                                 const dds_listener_t* listener = nullptr,
                                                 const char* topic_name = TopicOf<Sample>::name) {
  Result<dds_entity_t> t = p.topic<Sample>(topic_name);
  if (!t.ok()) return t;
  const dds_entity_t r = dds_create_reader(p.handle(), t.value(), qos, listener);
  if (r < 0) return Error{"dds: cannot create reader", 0, static_cast<long>(r)};
  return r;
}

template <class Sample>
[[nodiscard]] Result<dds_entity_t> create_writer(const Participant& p, const dds_qos_t* qos,
                                                 const char* topic_name = TopicOf<Sample>::name) {
  Result<dds_entity_t> t = p.topic<Sample>(topic_name);
  if (!t.ok()) return t;
  const dds_entity_t w = dds_create_writer(p.handle(), t.value(), qos, nullptr);
  if (w < 0) return Error{"dds: cannot create writer", 0, static_cast<long>(w)};
  return w;
}

}  // namespace teamscan::dds
