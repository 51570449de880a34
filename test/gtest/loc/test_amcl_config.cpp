// amcl's parameters: TurtleBot3's file loads with every key read and its values; an empty
// namespace gives stock amcl's defaults; every key stock amcl knows is accepted; each bad input
// (one fixture per error in test/data/loc/) gives one line naming the parameter.
#include <gtest/gtest.h>

#include "loc_test_helpers.h"

using namespace marl_mrta::loc;
using namespace marl_mrta::loc::testing;
using marl_mrta::nav::ParamError;
using marl_mrta::nav::ParamNode;

TEST(AmclConfig, Turtlebot3FileLoadsWithItsValues) {
  const AmclConfig config = tb3Config();
  EXPECT_EQ(500, config.filter.min_particles);
  EXPECT_EQ(3000, config.filter.max_particles);
  EXPECT_DOUBLE_EQ(0.02, config.filter.kld_err);
  EXPECT_DOUBLE_EQ(0.99, config.filter.kld_z);  // not in the file: stock default
  EXPECT_DOUBLE_EQ(0.20, config.update_min_d);
  EXPECT_DOUBLE_EQ(0.20, config.update_min_a);
  EXPECT_EQ(1, config.resample_interval);
  EXPECT_DOUBLE_EQ(0.5, config.transform_tolerance);
  EXPECT_DOUBLE_EQ(0.0, config.filter.alpha_slow);
  EXPECT_DOUBLE_EQ(0.0, config.filter.alpha_fast);
  EXPECT_DOUBLE_EQ(50.0, config.gui_publish_rate);
  EXPECT_DOUBLE_EQ(3.5, config.laser.max_range);
  EXPECT_EQ(180, config.laser.max_beams);
  EXPECT_DOUBLE_EQ(0.5, config.laser.z_hit);
  EXPECT_DOUBLE_EQ(0.5, config.laser.z_rand);
  EXPECT_DOUBLE_EQ(0.2, config.laser.sigma_hit);
  EXPECT_DOUBLE_EQ(2.0, config.laser_likelihood_max_dist);
  EXPECT_EQ(OdometryModelType::kDiff, config.odometry.type);
  EXPECT_DOUBLE_EQ(0.1, config.odometry.alpha1);
  EXPECT_DOUBLE_EQ(0.1, config.odometry.alpha4);
  EXPECT_TRUE(config.use_map_topic);
  EXPECT_EQ("tb3_0/odom", config.odom_frame_id);
  EXPECT_EQ("tb3_0/base_footprint", config.base_frame_id);
  EXPECT_EQ("map", config.global_frame_id);
}

TEST(AmclConfig, EmptyNamespaceGivesStockDefaults) {
  const AmclConfig config = readAmclConfig(ParamNode(YAML::Node(YAML::NodeType::Map), "amcl"));
  EXPECT_EQ(100, config.filter.min_particles);
  EXPECT_EQ(5000, config.filter.max_particles);
  EXPECT_DOUBLE_EQ(0.01, config.filter.kld_err);
  EXPECT_DOUBLE_EQ(0.99, config.filter.kld_z);
  EXPECT_DOUBLE_EQ(0.001, config.filter.alpha_slow);
  EXPECT_DOUBLE_EQ(0.1, config.filter.alpha_fast);
  EXPECT_DOUBLE_EQ(M_PI / 6.0, config.update_min_a);
  EXPECT_EQ(2, config.resample_interval);
  EXPECT_EQ(30, config.laser.max_beams);
  EXPECT_DOUBLE_EQ(0.95, config.laser.z_hit);
  EXPECT_DOUBLE_EQ(-1.0, config.laser.max_range);
  EXPECT_DOUBLE_EQ(0.2, config.odometry.alpha5);
  EXPECT_EQ("base_link", config.base_frame_id);
  EXPECT_FALSE(config.use_map_topic);
  EXPECT_TRUE(config.tf_broadcast);
  EXPECT_DOUBLE_EQ(0.5, config.save_pose_rate);
  EXPECT_DOUBLE_EQ(0.25, config.initial_covariance.xx);
  EXPECT_DOUBLE_EQ((M_PI / 12.0) * (M_PI / 12.0), config.initial_covariance.aa);
  EXPECT_EQ(0, config.seed);
}

TEST(AmclConfig, EveryKeyStockAmclKnowsIsAccepted) {
  const YAML::Node tree = amclTree(kSourceDir + "/test/data/loc/all_stock_keys.yaml");
  EXPECT_NO_THROW(readAmclConfig(ParamNode(tree, "tb3_0/amcl")));
}

TEST(AmclConfig, LeadingSlashesOfFramesAreStripped) {
  YAML::Node tree = amclTree();
  marl_mrta::nav::setParam(tree, "odom_frame_id", YAML::Node("/tb3_0/odom"));
  EXPECT_EQ("tb3_0/odom", readAmclConfig(ParamNode(tree, "tb3_0/amcl")).odom_frame_id);
}

TEST(AmclConfig, OdometryModelsByName) {
  for (const auto& [name, type] : std::vector<std::pair<std::string, OdometryModelType>>{
           {"diff", OdometryModelType::kDiff}, {"omni", OdometryModelType::kOmni},
           {"diff-corrected", OdometryModelType::kDiffCorrected}, {"omni-corrected", OdometryModelType::kOmniCorrected}}) {
    YAML::Node tree = amclTree();
    marl_mrta::nav::setParam(tree, "odom_model_type", YAML::Node(name));
    EXPECT_EQ(type, readAmclConfig(ParamNode(tree, "tb3_0/amcl")).odometry.type) << name;
  }
}

// One fixture per error, loaded over TurtleBot3's file; the whole message is matched.
struct BadParameter {
  std::string fixture;
  std::string message;
};

class AmclBadParameter : public ::testing::TestWithParam<BadParameter> {};

TEST_P(AmclBadParameter, GivesOneLineNamingTheParameter) {
  const YAML::Node tree = amclTree(kSourceDir + "/test/data/loc/" + GetParam().fixture);
  try {
    readAmclConfig(ParamNode(tree, "tb3_0/amcl"));
    FAIL() << GetParam().fixture << " was accepted";
  } catch (const ParamError& error) {
    EXPECT_EQ(GetParam().message, error.what());
    EXPECT_EQ(std::string::npos, std::string(error.what()).find('\n'));
  }
}

INSTANTIATE_TEST_SUITE_P(
    Fixtures, AmclBadParameter,
    ::testing::Values(
        BadParameter{"bad_unknown_key.yaml", "tb3_0/amcl/laser_z_hitt: unknown parameter"},
        BadParameter{"bad_laser_model_beam.yaml",
                     "tb3_0/amcl/laser_model_type: 'beam' is not available in the built-in amcl (likelihood_field only)"},
        BadParameter{"bad_laser_model_name.yaml",
                     "tb3_0/amcl/laser_model_type: unknown value 'gaussian' (expected likelihood_field, beam or "
                     "likelihood_field_prob)"},
        BadParameter{"bad_odom_model_name.yaml",
                     "tb3_0/amcl/odom_model_type: unknown value 'ackermann' (expected diff, omni, diff-corrected or "
                     "omni-corrected)"},
        BadParameter{"bad_min_above_max.yaml", "tb3_0/amcl/min_particles: must not exceed max_particles (3000), got 4000"},
        BadParameter{"bad_kld_err.yaml", "tb3_0/amcl/kld_err: must be in [1e-06, 1], got 0"},
        BadParameter{"bad_negative_alpha.yaml", "tb3_0/amcl/odom_alpha3: must be in [0, inf], got -0.1"},
        BadParameter{"bad_z_hit.yaml", "tb3_0/amcl/laser_z_hit: must be in [0, 1], got 1.5"},
        BadParameter{"bad_max_beams.yaml", "tb3_0/amcl/laser_max_beams: must be in [2, 2147483647], got 1"},
        BadParameter{"bad_resample_interval.yaml", "tb3_0/amcl/resample_interval: must be in [1, 2147483647], got 0"},
        BadParameter{"bad_update_min_d_type.yaml", "tb3_0/amcl/update_min_d: expected a number, got 'far'"},
        BadParameter{"bad_frame.yaml", "tb3_0/amcl/base_frame_id: must name a frame"},
        BadParameter{"bad_seed.yaml", "tb3_0/amcl/seed: must be in [0, 2147483647], got -1"},
        BadParameter{"bad_initial_cov.yaml", "tb3_0/amcl/initial_cov_xx: must be in [0, inf], got -0.1"},
        BadParameter{"bad_laser_range_order.yaml",
                     "tb3_0/amcl/laser_min_range: must be less than laser_max_range (3.5), got 4"},
        BadParameter{"bad_sigma_hit.yaml", "tb3_0/amcl/laser_sigma_hit: must be in [1e-06, inf], got 0"}),
    [](const ::testing::TestParamInfo<BadParameter>& info) {
      std::string name = info.param.fixture.substr(0, info.param.fixture.find('.'));
      for (char& c : name) if (c == '-') c = '_';
      return name;
    });
