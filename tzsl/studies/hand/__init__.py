"""The hand study (the DAP paper's Shadow-hand grasps, SIMULATED from Table 4): model, tables, figures."""
