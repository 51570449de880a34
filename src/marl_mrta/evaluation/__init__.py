"""The one episode loop and what is measured with it: policies over the environment, summaries
(the paper's Tables 8–9), Gantt charts, the decentralised board, comparisons. No ROS."""
