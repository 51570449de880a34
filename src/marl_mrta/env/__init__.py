"""The decision process (Algorithm 1), its interface (StepOutput, StepInfo, Policy) and the executors."""
