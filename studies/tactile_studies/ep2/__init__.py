"""EP2 studies (thesis ch. 4-5): test cases and their truth, figs. 30-34 and tables 5-7."""
