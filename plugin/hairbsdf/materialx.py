"""MaterialX chiang_hair_bsdf and its support nodes (placeholder, being written)."""


def chiang_hair_bsdf(**kwargs):
    raise NotImplementedError


def simple_hair_base(**kwargs):
    raise NotImplementedError
