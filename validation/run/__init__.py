"""The run's entry: validate a scene and write its report folder (:mod:`.validate`).

It stands above both the pipeline (``rigval.validation.pipeline``, which never imports the
report package) and the report (``rigval.validation.report``, written from the pipeline's
result alone), so it has a folder of its own: the layers run one way (docs/architecture.md).
"""
