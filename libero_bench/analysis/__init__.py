"""Reading results: reports and plots, lifelong metrics, intervals, paired comparisons of runs, saliency."""
