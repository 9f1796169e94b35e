"""What an engine can do, asked by feature: :func:`soft_gym.engines.engine_supports` and
:func:`~soft_gym.engines.engines_supporting` answer from the registry (:data:`ENGINES`, each
class's ``features``), and a plug-in engine is asked the same way."""

from __future__ import annotations

import pytest

from soft_gym.engines import (ENGINE_FEATURES, ENGINES, REFERENCE_ENGINE, engine_supports,
                              engines_supporting)
from soft_gym.envs.config import EnvConfig

pytestmark = pytest.mark.smoke


class _PlugInEngine:
    """A registered engine's class, for the queries alone (never built)."""

    features = frozenset({"rendering"})


@pytest.fixture
def plug_in_engine():
    ENGINES.register("plug_in", _PlugInEngine)
    try:
        yield "plug_in"
    finally:
        ENGINES.unregister("plug_in")


def test_every_engine_declares_only_known_features_and_every_feature_has_an_engine():
    for name in ENGINES:
        assert isinstance(ENGINES[name].features, frozenset), name
        assert ENGINES[name].features <= set(ENGINE_FEATURES), name
    offered = set().union(*(ENGINES[name].features for name in ENGINES))
    assert offered == set(ENGINE_FEATURES)


@pytest.mark.parametrize("feature", list(ENGINE_FEATURES))
def test_the_queries_answer_from_each_registered_class(feature):
    for name in ENGINES:
        assert engine_supports(name, feature) is (feature in ENGINES[name].features)
    assert engines_supporting(feature) == [name for name in ENGINES
                                           if feature in ENGINES[name].features]


def test_the_engines_offer_what_their_documentation_says():
    """The table of soft_gym.engines' docstring: the reference engine has bodies and cameras,
    the other steps arms as one batch."""
    assert engine_supports(REFERENCE_ENGINE, "bodies")
    assert engine_supports(REFERENCE_ENGINE, "rendering")
    assert not engine_supports(REFERENCE_ENGINE, "batched")
    assert engines_supporting("bodies", "rendering") == [REFERENCE_ENGINE]
    batched = engines_supporting("batched")
    assert batched and REFERENCE_ENGINE not in batched
    assert engines_supporting() == list(ENGINES)


def test_an_engine_that_batches_steps_a_batch():
    for name in engines_supporting("batched"):
        assert callable(ENGINES[name].step_batch), name


def test_the_reference_engine_is_registered_and_the_env_default():
    assert REFERENCE_ENGINE in ENGINES
    assert EnvConfig().engine == REFERENCE_ENGINE


def test_a_plug_in_engine_is_asked_by_its_features(plug_in_engine):
    assert engine_supports(plug_in_engine, "rendering")
    assert not engine_supports(plug_in_engine, "bodies")
    assert plug_in_engine in engines_supporting("rendering")
    assert plug_in_engine not in engines_supporting("bodies", "rendering")


@pytest.mark.parametrize("engine", ["bullet", "", None, ["mujoco"]])
def test_what_is_not_a_registered_engine_offers_nothing(engine):
    assert not any(engine_supports(engine, feature) for feature in ENGINE_FEATURES)


@pytest.mark.parametrize("feature", ["camera", "", None])
def test_an_unknown_feature_is_refused_naming_the_features(feature):
    message = rf"feature must be one of \['bodies', 'rendering', 'batched'\], got {feature!r}"
    with pytest.raises(ValueError, match=message):
        engine_supports(REFERENCE_ENGINE, feature)
    with pytest.raises(ValueError, match=message):
        engines_supporting("rendering", feature)
