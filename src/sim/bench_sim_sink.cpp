// Subscribes to every topic the simulator publishes, so that the node benchmark pays for
// serialising and sending each message (roscpp skips both for topics nobody subscribes to).
//
//   bench_sim_sink <robot namespace>...
//
// Exits once /clock has stopped for 2 s (wall) after running, printing one JSON line with the
// message counts.
#include <ros/callback_queue.h>
#include <ros/ros.h>

#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include <marl_mrta/CollisionEvent.h>
#include <marl_mrta/SimTick.h>
#include <nav_msgs/Odometry.h>
#include <rosgraph_msgs/Clock.h>
#include <sensor_msgs/LaserScan.h>
#include <tf2_msgs/TFMessage.h>

namespace {

std::map<std::string, long> counts;
ros::WallTime last_clock;

template <typename M>
ros::Subscriber count(ros::NodeHandle& nh, const std::string& topic) {
  counts[topic] = 0;
  return nh.subscribe<M>(topic, 1000, boost::function<void(const boost::shared_ptr<M const>&)>(
                                          [topic](const boost::shared_ptr<M const>&) { ++counts[topic]; }));
}

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "bench_sim_sink");
  ros::NodeHandle nh;
  std::vector<ros::Subscriber> subscribers;
  subscribers.push_back(nh.subscribe<rosgraph_msgs::Clock>(
      "/clock", 1000, boost::function<void(const rosgraph_msgs::Clock::ConstPtr&)>([](const rosgraph_msgs::Clock::ConstPtr&) {
        ++counts["/clock"];
        last_clock = ros::WallTime::now();
      })));
  subscribers.push_back(count<marl_mrta::SimTick>(nh, "/simulator/tick"));
  subscribers.push_back(count<marl_mrta::CollisionEvent>(nh, "/simulator/collisions"));
  subscribers.push_back(count<tf2_msgs::TFMessage>(nh, "/tf"));
  for (int i = 1; i < argc; ++i) {
    const std::string ns = std::string("/") + argv[i];
    subscribers.push_back(count<nav_msgs::Odometry>(nh, ns + "/odom"));
    subscribers.push_back(count<nav_msgs::Odometry>(nh, ns + "/base_pose_ground_truth"));
    subscribers.push_back(count<sensor_msgs::LaserScan>(nh, ns + "/scan"));
  }
  while (ros::ok()) {
    ros::getGlobalCallbackQueue()->callAvailable(ros::WallDuration(0.1));
    if (!last_clock.isZero() && (ros::WallTime::now() - last_clock).toSec() > 2.0) break;
  }
  std::printf("{");
  const char* separator = "";
  for (const auto& entry : counts) {
    std::printf("%s\"%s\": %ld", separator, entry.first.c_str(), entry.second);
    separator = ", ";
  }
  std::printf("}\n");
  return 0;
}
