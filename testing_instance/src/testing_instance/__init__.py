"""testing_instance: scenarios in sim time with expectations and verdicts, record and
replay (thesis chapter 2, figure 2.3)."""
