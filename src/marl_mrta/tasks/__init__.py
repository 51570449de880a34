"""Task logic of the decision process: rules of a step, reward, schedule record, travel times."""
