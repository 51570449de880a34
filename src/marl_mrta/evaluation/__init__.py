"""The evaluation command: methods through the environment, the paper's Tables 8–9, Gantt charts, benchmark."""
