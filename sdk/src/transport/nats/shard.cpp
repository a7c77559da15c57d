#include "transport/nats/shard.hpp"

#include <nats/nats.h>

#include <chrono>
#include <cstring>
#include <thread>

#include "transport/nats/results.hpp"
#include "transport/nats/topic.hpp"

namespace kata::transport::nats {

Shard::Shard(ShardOptions options, Handlers handlers) : options_(std::move(options)), handlers_(std::move(handlers)) {
  if (options_.connection.name.empty()) options_.connection.name = "kata-serve-" + options_.lease.member;
  options_.connection.single_delivery_thread = true;
  connection_ = std::make_unique<Connection>(options_.connection);
  partitions_.reset(new Partition[options_.lease.partitions]);
  for (uint32_t p = 0; p < options_.lease.partitions; ++p) {
    partitions_[p].shard = this;
    partitions_[p].index = p;
  }
  // The connection's options again: the lease loop's witnesses, one connection pinned to each server.
  leases_ = std::make_unique<LeaseManager>(*connection_, options_.lease, [this](const LeaseEvent& e) { on_lease(e); },
                                           &options_.connection);
}

Shard::~Shard() { stop(true); }

void Shard::stop(bool give_back) {
  if (stopped_) return;
  stopped_ = true;
  leases_->stop(give_back);  // gives back (on_lease drops each partition) or stops publishing
  for (uint32_t p = 0; p < options_.lease.partitions; ++p) drop(p);
  connection_->flush(1000);
  // Every subscription is closed; a handler already taken by the delivery thread finishes (and its
  // completion callback runs) before the shard, and what its handlers reach, may go away.
  while (live_subscriptions_.load(std::memory_order_acquire) > 0)
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
}

void Shard::on_complete(void* closure) {
  static_cast<Shard*>(closure)->live_subscriptions_.fetch_sub(1, std::memory_order_acq_rel);
}

void Shard::on_lease(const LeaseEvent& e) {
  Partition& part = partitions_[e.partition];
  switch (e.kind) {
    case LeaseEvent::Kind::kAcquired: {
      if (handlers_.on_acquired) handlers_.on_acquired(e.partition, e.epoch);
      part.open.store(true, std::memory_order_release);
      std::lock_guard<std::mutex> lock(subscriptions_mutex_);
      if (part.subscription == nullptr) {
        const std::string subject = partition_subject(options_.prefix, e.partition);
        if (natsConnection_Subscribe(&part.subscription, connection_->get(), subject.c_str(), &Shard::on_msg, &part) ==
            NATS_OK) {
          natsSubscription_SetPendingLimits(part.subscription, options_.pending_messages, -1);
          if (natsSubscription_SetOnCompleteCB(part.subscription, &Shard::on_complete, this) == NATS_OK)
            live_subscriptions_.fetch_add(1, std::memory_order_acq_rel);
        } else {
          part.subscription = nullptr;  // retried at the next acquisition; the partition's streams stay silent
        }
      }
      break;
    }
    case LeaseEvent::Kind::kReleased:
    case LeaseEvent::Kind::kLost:
      drop(e.partition);
      break;
    default:
      break;  // a pause keeps the subscription: frames keep flowing into the streams, results wait
  }
}

void Shard::drop(uint32_t p) {
  Partition& part = partitions_[p];
  const bool was_open = part.open.exchange(false, std::memory_order_acq_rel);
  std::unique_lock<std::mutex> lock(subscriptions_mutex_);
  if (part.subscription != nullptr) {
    int64_t dropped = 0;
    if (natsSubscription_GetDropped(part.subscription, &dropped) == NATS_OK)
      slow_consumer_ended_ += static_cast<uint64_t>(dropped);
    natsSubscription_Unsubscribe(part.subscription);
    natsSubscription_Destroy(part.subscription);
    part.subscription = nullptr;
  }
  lock.unlock();
  if (was_open && handlers_.on_dropped) handlers_.on_dropped(p);
}

void Shard::on_msg(natsConnection*, natsSubscription*, natsMsg* msg, void* closure) {
  auto* part = static_cast<Partition*>(closure);
  Shard& self = *part->shard;
  self.received_.fetch_add(1, std::memory_order_relaxed);
  const char* data = natsMsg_GetData(msg);
  const size_t size = static_cast<size_t>(natsMsg_GetDataLength(msg));
  uint32_t p = 0;
  uint64_t id = 0;
  if (!part->open.load(std::memory_order_acquire)) {
    self.not_held_.fetch_add(1, std::memory_order_relaxed);
  } else if (size > self.options_.max_message_bytes) {
    self.oversized_.fetch_add(1, std::memory_order_relaxed);
  } else if (!parse_partition_subject(self.options_.prefix, natsMsg_GetSubject(msg), &p, &id) || p != part->index ||
             partition_of(id, self.options_.lease.partitions) != p || size < kStreamTopicBytes ||
             std::memcmp(data, natsMsg_GetSubject(msg) + std::strlen(natsMsg_GetSubject(msg)) - kStreamTopicBytes,
                         kStreamTopicBytes) != 0) {
    self.wrong_partition_.fetch_add(1, std::memory_order_relaxed);
  } else {
    self.handed_on_.fetch_add(1, std::memory_order_relaxed);
    if (self.handlers_.on_message) self.handlers_.on_message(data, size);
  }
  natsMsg_Destroy(msg);
}

bool Shard::publish_result(uint64_t stream_id, const void* data, size_t size) {
  const int outcome = publish(stream_id, data, size, subject_, sizeof subject_);
  (outcome == 0 ? results_published_ : outcome == 1 ? results_not_held_ : results_failed_)
      .fetch_add(1, std::memory_order_relaxed);
  return outcome == 0;
}

bool Shard::publish_definition(uint64_t stream_id, const void* data, size_t size) {
  return 0 == publish(stream_id, data, size, definition_subject_, sizeof definition_subject_);
}

int Shard::publish(uint64_t stream_id, const void* data, size_t size, char* subject, size_t capacity) {
  uint64_t epoch = 0;
  if (!leases_->may_publish(partition_of(stream_id, options_.lease.partitions), &epoch)) return 1;
  if (!format_result_subject(subject, capacity, options_.prefix, stream_id, epoch, options_.lease.member) ||
      natsConnection_Publish(connection_->get(), subject, data, static_cast<int>(size)) != NATS_OK) {
    return 2;
  }
  return 0;
}

ShardCounters Shard::counters() const {
  ShardCounters c;
  c.received = received_.load();
  c.handed_on = handed_on_.load();
  c.oversized = oversized_.load();
  c.wrong_partition = wrong_partition_.load();
  c.not_held = not_held_.load();
  {
    std::lock_guard<std::mutex> lock(subscriptions_mutex_);
    c.slow_consumer = slow_consumer_ended_;
    for (uint32_t p = 0; p < options_.lease.partitions; ++p) {
      int64_t dropped = 0;
      if (partitions_[p].subscription != nullptr && natsSubscription_GetDropped(partitions_[p].subscription, &dropped) == NATS_OK)
        c.slow_consumer += static_cast<uint64_t>(dropped);
    }
  }
  c.results_published = results_published_.load();
  c.results_not_held = results_not_held_.load();
  c.results_failed = results_failed_.load();
  c.partitions_held = leases_->held().size();
  c.disconnects = connection_->disconnects();
  c.reconnects = connection_->reconnects();
  c.leases = leases_->counters();
  return c;
}

}  // namespace kata::transport::nats
