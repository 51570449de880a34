// The lock-step bookkeeping and the real-time pacing of the node's loop.
#include <gtest/gtest.h>

#include "marl_mrta/sim/lockstep_gate.h"

namespace marl_mrta {
namespace sim {
namespace {

TEST(LockstepGate, AdvancesOnlyWhenEveryParticipantAnsweredWithItsCommands) {
  LockstepGate gate({true, false, true});  // robot 1 has no lock-step controller
  EXPECT_FALSE(gate.answered(0));
  EXPECT_EQ(gate.missing(0), (std::vector<int>{0, 2}));
  EXPECT_TRUE(gate.ackReceived(0, 0, 0, 0, 0));
  EXPECT_FALSE(gate.ackReceived(1, 0, 0, 0, 0));  // not participating: ignored
  EXPECT_FALSE(gate.answered(0));
  // Robot 2 acks one command that has not arrived yet.
  EXPECT_TRUE(gate.ackReceived(2, 0, 1, 0, 0));
  EXPECT_EQ(gate.missing(0), (std::vector<int>{2}));
  gate.commandReceived(2);
  EXPECT_TRUE(gate.answered(0));
  // The next tick needs new answers.
  EXPECT_FALSE(gate.answered(1));
  gate.ackReceived(0, 1, 0, 0, 1);
  gate.ackReceived(2, 1, 1, 0, 1);
  EXPECT_TRUE(gate.answered(1));
}

TEST(LockstepGate, StaleAndEarlyAcksAreIgnored) {
  LockstepGate gate({true});
  gate.ackReceived(0, 4, 0, 0, 5);  // answer to an earlier (re-sent) tick
  EXPECT_FALSE(gate.answered(5));
  gate.ackReceived(0, 6, 0, 0, 5);  // for a tick not reached yet
  EXPECT_FALSE(gate.answered(5));
  gate.ackReceived(0, 5, 0, 0, 5);
  EXPECT_TRUE(gate.answered(5));
}

TEST(LockstepGate, TicksBeforeTheNextNeededOneAreNotWaitedFor) {
  LockstepGate gate({true, true});
  gate.ackReceived(0, 10, 0, 12, 10);  // robot 0 acts again at tick 12
  gate.ackReceived(1, 10, 0, 0, 10);   // robot 1 answers every tick
  EXPECT_TRUE(gate.answered(10));
  EXPECT_EQ(gate.missing(11), (std::vector<int>{1}));
  gate.ackReceived(1, 11, 0, 0, 11);
  EXPECT_TRUE(gate.answered(11));
  EXPECT_EQ(gate.missing(12), (std::vector<int>{0, 1}));
  // A command counted by the skipping ack still has to arrive before any later tick.
  gate.ackReceived(0, 12, 1, 14, 12);
  gate.ackReceived(1, 12, 0, 0, 12);
  EXPECT_EQ(gate.missing(12), (std::vector<int>{0}));
  EXPECT_EQ(gate.missing(13), (std::vector<int>{0, 1}));
  gate.commandReceived(0);
  gate.ackReceived(1, 13, 0, 0, 13);
  EXPECT_TRUE(gate.answered(13));
  EXPECT_FALSE(gate.answered(14));
}

TEST(LockstepGate, NobodyParticipatingNeverWaits) {
  LockstepGate gate({false, false});
  EXPECT_TRUE(gate.answered(0));
  EXPECT_TRUE(gate.answered(17));
}

TEST(GoalEndWatch, PausesOnTheAlignedTickAfterTheLastWatchedGoalEnds) {
  GoalEndWatch watch(3);
  watch.goalEnded(0, 12);  // before the watch: does not count
  watch.start({0, 1}, 40, 20);
  EXPECT_TRUE(watch.active());
  EXPECT_EQ(watch.pauseTick(), 0u);
  watch.goalEnded(1, 47);
  EXPECT_EQ(watch.pauseTick(), 0u) << "robot 0 has not ended a goal since tick 40";
  watch.goalEnded(2, 50);  // not watched
  EXPECT_EQ(watch.pauseTick(), 0u);
  watch.goalEnded(0, 40);  // a goal ended (cancelled) on the start tick itself: before the run
  EXPECT_EQ(watch.pauseTick(), 0u);
  watch.goalEnded(0, 61);
  EXPECT_EQ(watch.pauseTick(), 80u) << "the first multiple of 20 at or after tick 61";
  watch.goalEnded(1, 30);  // an older report changes nothing
  EXPECT_EQ(watch.pauseTick(), 80u);
  watch.clear();
  EXPECT_FALSE(watch.active());
  EXPECT_EQ(watch.pauseTick(), 0u);
}

TEST(GoalEndWatch, AnAlignedEndOrNoAlignmentPausesOnTheEndTick) {
  GoalEndWatch watch(1);
  watch.start({0}, 0, 20);
  watch.goalEnded(0, 60);
  EXPECT_EQ(watch.pauseTick(), 60u);
  watch.start({0}, 60, 0);
  watch.goalEnded(0, 73);
  EXPECT_EQ(watch.pauseTick(), 73u);
  watch.start({}, 73, 20);
  EXPECT_FALSE(watch.active());
  EXPECT_EQ(watch.pauseTick(), 0u);
}

TEST(GoalEndWatch, WithFirstPausesOnTheAlignedTickAfterTheFirstWatchedGoalEnds) {
  GoalEndWatch watch(3);
  watch.goalEnded(0, 12);  // before the watch: does not count
  watch.start({0, 1}, 40, 1, true);
  EXPECT_TRUE(watch.active());
  EXPECT_EQ(watch.pauseTick(), 0u) << "no watched goal has ended since tick 40";
  watch.goalEnded(2, 45);  // not watched
  EXPECT_EQ(watch.pauseTick(), 0u);
  watch.goalEnded(0, 40);  // ended (cancelled) on the start tick itself: before the run
  EXPECT_EQ(watch.pauseTick(), 0u);
  watch.goalEnded(1, 47);
  EXPECT_EQ(watch.pauseTick(), 47u) << "robot 1 came free on tick 47; robot 0 still drives";
  watch.goalEnded(0, 52);  // a later end does not move the pause
  EXPECT_EQ(watch.pauseTick(), 47u);
  // Aligned: the first multiple of 20 at or after the earliest end; the last end would be 80.
  watch.start({0, 1}, 52, 20, true);
  watch.goalEnded(1, 61);
  EXPECT_EQ(watch.pauseTick(), 80u);
  watch.goalEnded(0, 55);
  EXPECT_EQ(watch.pauseTick(), 60u);
  // The same reports watched for the last end (synchronous mode) wait for both.
  watch.start({0, 1}, 52, 20);
  EXPECT_EQ(watch.pauseTick(), 80u);
  watch.start({0, 1, 2}, 52, 20);
  EXPECT_EQ(watch.pauseTick(), 0u) << "robot 2 has not ended a goal since tick 52";
  watch.start({0, 1, 2}, 52, 20, true);
  EXPECT_EQ(watch.pauseTick(), 60u);
  watch.clear();
  EXPECT_EQ(watch.pauseTick(), 0u);
}

TEST(RealTimePacer, StepsAreDueAtTheRealTimeFactor) {
  RealTimePacer pacer(20.0, 2.0, 1.0);  // a tick every 0.025 s of wall time
  EXPECT_NEAR(pacer.waitBeforeStep(100.0, 0), 0.025, 1e-12);
  EXPECT_EQ(pacer.waitBeforeStep(100.025, 0), 0.0);
  EXPECT_NEAR(pacer.waitBeforeStep(100.030, 1), 0.020, 1e-9);
  // A short delay is caught up: the next steps are due at once.
  EXPECT_EQ(pacer.waitBeforeStep(100.2, 2), 0.0);
  EXPECT_EQ(pacer.waitBeforeStep(100.2, 3), 0.0);
  EXPECT_NEAR(pacer.waitBeforeStep(100.2, 7), 0.0, 1e-12);
  EXPECT_NEAR(pacer.waitBeforeStep(100.2, 8), 0.025, 1e-9);
}

TEST(RealTimePacer, ALongLagStartsAfreshAndZeroMeansAsFastAsPossible) {
  RealTimePacer pacer(20.0, 1.0, 1.0);
  EXPECT_NEAR(pacer.waitBeforeStep(0.0, 0), 0.05, 1e-12);
  EXPECT_EQ(pacer.waitBeforeStep(5.0, 0), 0.0);           // 4.95 s late: step, then re-anchor
  EXPECT_NEAR(pacer.waitBeforeStep(5.0, 1), 0.05, 1e-12);  // paced from now on, no burst
  RealTimePacer unpaced(20.0, 0.0, 1.0);
  EXPECT_EQ(unpaced.waitBeforeStep(0.0, 0), 0.0);
  EXPECT_EQ(unpaced.waitBeforeStep(0.0, 1000), 0.0);
}

}  // namespace
}  // namespace sim
}  // namespace marl_mrta
