"""The paper's GA against gradient RL (PPO and SAC, Stable-Baselines3) at equal learner-steps
(``enn-traffic baseline``; docs/results.md, "The GA against gradient RL"), and the spin rule's
second setting it is measured under."""
