"""sphpost.figures: what the tools' figures share: matplotlib without a
display."""


def use_agg():
    """matplotlib with the headless Agg backend."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt
