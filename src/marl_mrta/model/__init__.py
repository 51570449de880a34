"""The model: maps, scenarios, task rules, reward, schedule record, robot, noise profiles, travel times."""
