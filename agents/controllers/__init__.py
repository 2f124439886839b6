"""Classical path trackers: pure pursuit, regulated pure pursuit and seed 003's guidance laws."""
