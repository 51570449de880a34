// Publishing per-tick messages through a shared pointer. roscpp hands a message published by
// reference to subscribers in the same process (nodelets) only after serializing it and waking
// its network thread, which then queues it for the subscriber's thread: two thread hand-overs
// and a copy through bytes per message. A shared pointer goes straight to their callback queues
// from the publishing thread; it is serialized only for subscribers in other processes.
#pragma once

#include <ros/publisher.h>

#include <boost/make_shared.hpp>

namespace marl_mrta {

// Publishes a copy of `message`: the caller may reuse `message` at once (subscribers keep the copy).
template <typename Message>
void publishShared(const ros::Publisher& publisher, const Message& message) {
  publisher.publish(boost::make_shared<Message>(message));
}

}  // namespace marl_mrta
