"""The gateway's ROS-free parts: device entries, endpoint and security, PackML states, users, arguments."""

from __future__ import annotations

import math
import os
from pathlib import Path

import pytest

from feeder_cell.gateway import layout, units
from feeder_cell.gateway.arguments import Argument, ArgumentError
from feeder_cell.gateway.certificates import CERTIFICATE_NAME, KEY_NAME, ensure_certificate, thumbprints
from feeder_cell.gateway.config import (
    PACKML_STATES,
    check_security,
    is_loopback,
    is_warning,
    packml_state,
    parse_device_entry,
    parse_devices,
    parse_endpoint,
    security_warnings,
)
from feeder_cell.gateway.kinds.assembly_fixture import check_follow_path
from feeder_cell.gateway.kinds.mems_field_array import check_run_program
from feeder_cell.gateway.kinds.throwing_arm import check_feed_part
from feeder_cell.gateway.users import Users, hash_password, load_users, verify_password
from feeder_planner.errors import InputError

ROOT = Path(__file__).resolve().parents[2]
FEED = layout.ACTIONS["throwing_arm"]
RUN = layout.ACTIONS["mems_field_array"]
FOLLOW = layout.ACTIONS["assembly_fixture"]


def d(value: float) -> Argument:
    return Argument(value, "Double")


def u(value: int) -> Argument:
    return Argument(value, "UInt32")


# --- devices, endpoint, security ---------------------------------------------------------------------


def test_device_kind_from_the_node_name_or_given() -> None:
    arm = parse_device_entry("/cell/throwing_arm", 0)
    assert (arm.kind, arm.node, arm.key) == ("throwing_arm", "/cell/throwing_arm", "cell.throwing_arm")
    named = parse_device_entry("assembly_fixture:/cell/tilt_a", 1)
    assert (named.kind, named.key) == ("assembly_fixture", "cell.tilt_a")


@pytest.mark.parametrize(
    "entry, words",
    [
        ("/cell/feeder_a", "give the kind explicitly"),
        ("robot:/cell/x", "unknown device kind 'robot'"),
        ("cell/throwing_arm", "fully qualified node name"),
        ("/cell/bad-name", "fully qualified node name"),
    ],
)
def test_bad_device_entries_name_the_entry(entry: str, words: str) -> None:
    with pytest.raises(InputError) as error:
        parse_devices(["", entry])
    assert str(error.value).startswith("parameter devices[1]:")
    assert words in str(error.value)


def test_a_device_listed_twice_is_refused() -> None:
    with pytest.raises(InputError, match=r"devices\[1\].*listed twice"):
        parse_devices(["/a/throwing_arm", "throwing_arm:/a/throwing_arm"])


def test_endpoint_parsing() -> None:
    endpoint = parse_endpoint("opc.tcp://127.0.0.1:4840")
    assert (endpoint.host, endpoint.port) == ("127.0.0.1", 4840)
    for bad in ("http://127.0.0.1:4840", "opc.tcp://127.0.0.1", "opc.tcp://:4840", "opc.tcp://h:99999"):
        with pytest.raises(InputError, match="parameter endpoint"):
            parse_endpoint(bad)


def test_loopback() -> None:
    assert is_loopback("127.0.0.1") and is_loopback("::1") and is_loopback("localhost")
    assert not is_loopback("0.0.0.0") and not is_loopback("10.1.2.3") and not is_loopback("plc-gateway")


def _security(url: str, **overrides: object) -> object:
    values: dict = dict(
        policies=["None"],
        certificate_file="",
        private_key_file="",
        allow_anonymous=True,
        allow_anonymous_remote=False,
        users_file="",
    )
    values.update(overrides)
    return check_security(parse_endpoint(url), **values)  # type: ignore[arg-type]


def test_anonymous_on_a_non_loopback_endpoint_is_refused_unless_allowed_explicitly() -> None:
    assert _security("opc.tcp://127.0.0.1:4840").allow_anonymous  # type: ignore[attr-defined]
    with pytest.raises(InputError) as error:
        _security("opc.tcp://0.0.0.0:4840")
    assert str(error.value).startswith("parameter allow_anonymous:")
    assert "allow_anonymous_remote" in str(error.value)
    assert _security("opc.tcp://0.0.0.0:4840", allow_anonymous_remote=True, allow_insecure_remote=True)


def test_security_combinations_name_the_parameter(tmp_path: Path) -> None:
    with pytest.raises(InputError, match=r"parameter security_policies\[0\]: unknown policy 'Basic128'"):
        _security("opc.tcp://127.0.0.1:1", policies=["Basic128"])
    with pytest.raises(InputError, match="parameter certificate_file: is required with private_key_file"):
        _security("opc.tcp://127.0.0.1:1", policies=[SECURE], private_key_file=str(tmp_path / "key.pem"))
    with pytest.raises(InputError, match="parameter private_key_file: is required with certificate_file"):
        _security("opc.tcp://127.0.0.1:1", policies=[SECURE], certificate_file=str(tmp_path / "cert.der"))
    # Neither: the node makes (or reuses) a self-signed certificate in pki_dir.
    assert _security("opc.tcp://127.0.0.1:1", policies=[SECURE]).makes_certificate  # type: ignore[attr-defined]
    with pytest.raises(InputError, match="parameter pki_dir: is used only when a Basic256Sha256 policy"):
        _security("opc.tcp://127.0.0.1:1", pki_dir=str(tmp_path))
    with pytest.raises(InputError, match="parameter allow_anonymous: is false and no users_file"):
        _security("opc.tcp://127.0.0.1:1", allow_anonymous=False)
    with pytest.raises(InputError, match="parameter users_file: cannot read"):
        _security("opc.tcp://127.0.0.1:1", users_file=str(tmp_path / "missing.yaml"))
    with pytest.raises(InputError, match="parameter trusted_certificates_dir: applies to the Basic256Sha256"):
        _security("opc.tcp://127.0.0.1:1", trusted_certificates_dir=str(tmp_path))


SECURE = "Basic256Sha256_SignAndEncrypt"
REMOTE = "opc.tcp://10.1.2.3:4840"


def _users_file(tmp_path: Path) -> str:
    path = tmp_path / "users.yaml"
    path.write_text(f"users:\n  plc: {hash_password('x', iterations=1)}\n")
    return str(path)


def test_off_loopback_none_is_refused_unless_allowed_explicitly(tmp_path: Path) -> None:
    users = _users_file(tmp_path)
    for policies in (["None"], ["None", SECURE]):
        with pytest.raises(InputError) as error:
            _security(REMOTE, policies=policies, allow_anonymous=False, users_file=users)
        assert str(error.value).startswith("parameter security_policies: offers None")
        assert "allow_insecure_remote" in str(error.value) and "\n" not in str(error.value)
    config = _security(REMOTE, allow_anonymous=False, users_file=users, allow_insecure_remote=True)
    assert config.insecure_remote  # type: ignore[attr-defined]
    # On loopback None stays the default, and nothing is said about it.
    assert not _security("opc.tcp://127.0.0.1:4840").insecure_remote  # type: ignore[attr-defined]


def test_off_loopback_sign_alone_is_not_enough_beside_sign_and_encrypt_it_is(tmp_path: Path) -> None:
    users = _users_file(tmp_path)
    with pytest.raises(InputError, match="parameter security_policies: offers no encryption"):
        _security(REMOTE, policies=["Basic256Sha256_Sign"], allow_anonymous=False, users_file=users)
    for policies in ([SECURE], ["Basic256Sha256_Sign", SECURE]):
        config = _security(REMOTE, policies=policies, allow_anonymous=False, users_file=users)
        assert config.remote and not config.insecure_remote  # type: ignore[attr-defined]
        assert config.makes_certificate  # type: ignore[attr-defined]


def test_off_loopback_sessions_need_users_or_explicit_anonymous(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="parameter allow_anonymous: is false and no users_file"):
        _security(REMOTE, policies=[SECURE], allow_anonymous=False)
    with pytest.raises(
        InputError, match="parameter allow_anonymous: anonymous clients are allowed on a loop"
    ):
        _security(REMOTE, policies=[SECURE], users_file=_users_file(tmp_path))
    assert _security(REMOTE, policies=[SECURE], allow_anonymous_remote=True).allow_anonymous  # type: ignore[attr-defined]
    # A host name is not provably loopback: it is held to the same rules.
    with pytest.raises(InputError, match="parameter allow_anonymous"):
        _security("opc.tcp://plc-gateway:4840", policies=[SECURE])


def test_each_explicit_opt_out_is_a_warning_naming_its_parameter(tmp_path: Path) -> None:
    endpoint = parse_endpoint(REMOTE)
    quiet = _security(REMOTE, policies=[SECURE], allow_anonymous=False, users_file=_users_file(tmp_path))
    assert security_warnings(endpoint, quiet) == []  # type: ignore[arg-type]
    loud = _security(REMOTE, allow_anonymous_remote=True, allow_insecure_remote=True)
    warnings = security_warnings(endpoint, loud)  # type: ignore[arg-type]
    assert [w.split(":", 1)[0] for w in warnings] == [
        "parameter allow_anonymous_remote",
        "parameter allow_insecure_remote",
    ]
    plain = _security(
        REMOTE, allow_anonymous=False, users_file=_users_file(tmp_path), allow_insecure_remote=True
    )
    assert any(
        w.startswith("parameter users_file: passwords cross") for w in security_warnings(endpoint, plain)
    )  # type: ignore[arg-type]
    assert (
        security_warnings(parse_endpoint("opc.tcp://127.0.0.1:1"), _security("opc.tcp://127.0.0.1:1")) == []
    )  # type: ignore[arg-type]


def test_the_certificate_is_made_once_then_reused_and_a_bad_folder_names_pki_dir(tmp_path: Path) -> None:
    from cryptography import x509

    pki = tmp_path / "pki"
    made = ensure_certificate(str(pki), layout.APPLICATION_URI, "10.1.2.3")
    assert made.created and Path(made.certificate_file) == pki / CERTIFICATE_NAME
    assert os.stat(made.private_key_file).st_mode & 0o077 == 0
    der = (pki / CERTIFICATE_NAME).read_bytes()
    assert (made.sha1, made.sha256) == thumbprints(der) and len(made.sha1.split(":")) == 20
    certificate = x509.load_der_x509_certificate(der)
    names = certificate.extensions.get_extension_for_class(x509.SubjectAlternativeName).value
    assert names.get_values_for_type(x509.UniformResourceIdentifier) == [layout.APPLICATION_URI]
    assert "10.1.2.3" in [str(a) for a in names.get_values_for_type(x509.IPAddress)]
    assert certificate.public_key().key_size == 2048  # type: ignore[union-attr]
    again = ensure_certificate(str(pki), layout.APPLICATION_URI, "10.1.2.3")
    assert not again.created and again.sha256 == made.sha256 and (pki / CERTIFICATE_NAME).read_bytes() == der
    with pytest.raises(
        InputError, match="parameter pki_dir: .* is for urn:feeder:cell:opcua_gateway, not urn:other"
    ):
        ensure_certificate(str(pki), "urn:other", "10.1.2.3")
    (pki / KEY_NAME).unlink()
    with pytest.raises(InputError, match=f"parameter pki_dir: has {CERTIFICATE_NAME} without {KEY_NAME}"):
        ensure_certificate(str(pki), layout.APPLICATION_URI, "10.1.2.3")
    blocker = tmp_path / "a_file"
    blocker.write_text("")
    with pytest.raises(InputError, match="parameter pki_dir: cannot use"):
        ensure_certificate(str(blocker / "pki"), layout.APPLICATION_URI, "10.1.2.3")


def test_without_a_none_endpoint_a_channel_without_a_client_certificate_gets_no_session() -> None:
    from feeder_cell.gateway.server import GatewayUsers

    users = Users({"plc": hash_password("line-7", iterations=1)})
    secure_only = GatewayUsers(users, allow_anonymous=True, secure_only=True)
    assert secure_only.get_user(None, "plc", "line-7", certificate=b"client certificate") is not None  # type: ignore[arg-type]
    assert secure_only.get_user(None, certificate=b"client certificate") is not None  # type: ignore[arg-type]
    # asyncua lets a None channel through whatever the policies; without a certificate nobody gets in.
    assert secure_only.get_user(None, "plc", "line-7", certificate=None) is None  # type: ignore[arg-type]
    assert secure_only.get_user(None, certificate=None) is None  # type: ignore[arg-type]
    assert GatewayUsers(users, allow_anonymous=True).get_user(None, "plc", "line-7") is not None  # type: ignore[arg-type]


def test_packml_mapping() -> None:
    names = {state: packml_state(state) for state in range(6)}
    assert names == {
        0: ("Unconfigured", 100),  # not Stopped: Reset does not help, the lifecycle must configure it
        1: ("Idle", 4),
        2: ("Execute", 6),
        3: ("Suspended", 5),
        4: ("Aborted", 9),
        5: ("Stopped", 2),
    }
    assert packml_state(None) == ("Undefined", 0)
    assert packml_state(17) == ("Undefined", 0)
    # The enumeration: ISA-TR88.00.02 StateCurrent numbers 0..17 (OPC 30050's StateNumbers), plus the
    # gateway's own Unconfigured outside that range; every mapped state is one of its entries.
    numbers = {number: name for number, name, _ in PACKML_STATES}
    assert [numbers[n] for n in (0, 1, 2, 4, 5, 6, 9, 15, 17)] == [
        "Undefined",
        "Clearing",
        "Stopped",
        "Idle",
        "Suspended",
        "Execute",
        "Aborted",
        "Resetting",
        "Complete",
    ]
    assert sorted(numbers) == [*range(18), 100]
    for name, number in names.values():
        assert numbers[number] == name


def test_warnings_are_codes_of_an_operational_device_faults_the_others() -> None:
    idle, running, paused, fault, stopped, unconfigured = 1, 2, 3, 4, 5, 0
    # A stopped device behind real time (code 2) is not faulted: stopping faults put it in FAULT.
    for state in (idle, running, paused, stopped):
        assert is_warning(state, 2) and is_warning(state, 302)
        assert not is_warning(state, 0)
    for state in (fault, unconfigured):
        assert not is_warning(state, 101) and not is_warning(state, 1)


# --- users --------------------------------------------------------------------------------------------


def test_password_hashes_are_salted_and_checked(tmp_path: Path) -> None:
    first, second = hash_password("secret", iterations=1000), hash_password("secret", iterations=1000)
    assert first != second  # a fresh salt each time
    assert verify_password("secret", first) and not verify_password("Secret", first)
    path = tmp_path / "users.yaml"
    path.write_text(f'users:\n  plc: {{role: Operator, hash: "{first}"}}\n')
    users = load_users(str(path))
    assert users.check("plc", "secret")
    assert (
        not users.check("plc", "wrong") and not users.check("other", "secret") and not users.check(None, None)
    )


def test_a_bad_users_file_names_the_entry(tmp_path: Path) -> None:
    path = tmp_path / "users.yaml"
    path.write_text("users:\n  plc: {role: Operator, hash: plaintext}\n")
    with pytest.raises(InputError) as error:
        load_users(str(path))
    assert "parameter users_file" in str(error.value) and "users.plc.hash" in str(error.value)
    assert isinstance(Users({}), Users)


# --- arguments ----------------------------------------------------------------------------------------


def _refused(call: object, *args: object) -> ArgumentError:
    with pytest.raises(ArgumentError) as error:
        call(*args)  # type: ignore[operator]
    return error.value


def test_feed_part_arguments() -> None:
    goal = check_feed_part(FEED, [u(5), d(2.5)])
    assert (goal.max_throws, goal.timeout) == (5, 2.5)
    assert check_feed_part(FEED, [u(3), d(0.0)]).timeout == 0.0
    error = _refused(check_feed_part, FEED, [u(0), d(1.0)])
    assert (error.status, error.index) == ("BadInvalidArgument", 0) and "MaxThrows" in error.message
    error = _refused(check_feed_part, FEED, [u(1), d(math.nan)])
    assert (error.status, error.index) == ("BadInvalidArgument", 1) and "Timeout" in error.message
    error = _refused(check_feed_part, FEED, [u(1), Argument("soon", "String")])
    assert (error.status, error.index) == ("BadTypeMismatch", 1) and "Timeout" in error.message
    error = _refused(check_feed_part, FEED, [u(1)])
    assert error.status == "BadArgumentsMissing" and "Timeout" in error.message
    error = _refused(check_feed_part, FEED, [u(1), d(1.0), d(2.0)])
    assert error.status == "BadTooManyArguments"


def test_run_program_inline_and_files(tmp_path: Path) -> None:
    inline = "{steps: [{field: {type: radial, center: [0, 0]}, duration: .inf}]}"
    goal = check_run_program(RUN, [Argument(inline, "String"), d(5.0), d(0.0), d(0.0)], "")
    assert goal.name == "inline" and len(goal.steps) == 1 and goal.timeout == 5.0
    programs = ROOT / "examples" / "mems"
    named = check_run_program(
        RUN, [Argument("program_squeeze_then_orient", "String"), d(5.0), d(0.0), d(0.0)], str(programs)
    )
    assert named.name == "program_squeeze_then_orient" and len(named.steps) == 3
    for text, words in (
        ("", "Program: is empty"),
        ("{steps: []}", "Program.steps"),
        ("{steps: [{field: {type: spiral}}]}", "Program.steps[0].field"),
        ("../secrets.yaml", "inside program_dir"),
        ("/etc/passwd", "inside program_dir"),
        ("missing", "no program 'missing'"),
        ("{steps: [", "inline program: not valid YAML"),
        (
            "{a: &a [1, 1, 1, 1, 1, 1, 1, 1, 1, 1], "
            + ", ".join(
                f"{chr(98 + i)}: &{chr(98 + i)} [" + ", ".join([f"*{chr(97 + i)}"] * 10) + "]"
                for i in range(6)
            )
            + "}",
            "aliases expanded",
        ),
        ("{" + "x" * (2 << 20) + "}", "characters, at most"),
    ):
        error = _refused(
            check_run_program, RUN, [Argument(text, "String"), d(5.0), d(0.0), d(0.0)], str(programs)
        )
        assert (error.status, error.index) == ("BadInvalidArgument", 0), text
        assert words in error.message, (text, error.message)
    error = _refused(check_run_program, RUN, [Argument(inline, "String"), d(0.0), d(0.0), d(0.0)], "")
    assert error.index == 1 and "Timeout: must be > 0" in error.message
    error = _refused(check_run_program, RUN, [Argument(inline, "String"), d(1.0), d(-1.0), d(0.0)], "")
    assert error.index == 2 and "Tolerance" in error.message
    error = _refused(check_run_program, RUN, [Argument("x", "String"), d(1.0), d(0.0), d(0.0)], "")
    assert "program_dir is empty" in error.message


def test_follow_path_arguments() -> None:
    tilt = check_follow_path(
        FOLLOW, [Argument([0.1, 0.0, 0.0, 0.0], "Double", True), Argument([], "Null", True)]
    )
    assert tilt.tilt == (0.1, 0.0, 0.0, 0.0) and tilt.gravity == ()
    gravity = check_follow_path(FOLLOW, [Argument(None, "Null"), Argument([0.0, 0.0, -1.0], "Double", True)])
    assert gravity.gravity == ((0.0, 0.0, -1.0),)
    cases = [
        ([Argument([], "Double", True), Argument([], "Double", True)], 1, "both are empty"),
        (
            [Argument([0.1, 0.2], "Double", True), Argument([0.0, 0.0, -1.0], "Double", True)],
            0,
            "both are given",
        ),
        ([Argument([0.1], "Double", True), Argument([], "Double", True)], 0, "pairs"),
        ([Argument([], "Double", True), Argument([0.0, -1.0], "Double", True)], 1, "triples"),
        ([Argument([], "Double", True), Argument([0.0, 0.0, 0.0], "Double", True)], 1, "zero vector"),
        ([Argument([0.1, math.nan], "Double", True), Argument([], "Double", True)], 0, "TiltWaypoints[1]"),
    ]
    for args, index, words in cases:
        error = _refused(check_follow_path, FOLLOW, args)
        assert (error.status, error.index) == ("BadInvalidArgument", index) and words in error.message, words
    error = _refused(check_follow_path, FOLLOW, [Argument(0.5, "Double"), Argument([], "Double", True)])
    assert error.status == "BadTypeMismatch" and "TiltWaypoints" in error.message


def test_layout_ids_are_unique_per_device() -> None:
    for kind in layout.COUNTERS:
        paths = [v.path for v in layout.variables(kind)]
        assert len(paths) == len(set(paths))
        assert {"Status.PackMLState", "Status.FaultCode", "Command.LastOutcome", "Command.Busy"} <= set(paths)
        names = [m.name for m in layout.methods(kind)]
        assert names[0] == layout.ACTIONS[kind].name
        common = ["Stop", "Reset", "Clear", "Abort", "Suspend", "Unsuspend", "Unconfigure"]
        assert names[-9:] == [*common, "InjectFault", "ClearFault"]
        assert len(names) == len(set(names))
    assert layout.variable_id("cell.throwing_arm", "Signals.Sensor") == "cell.throwing_arm.Signals.Sensor"


def test_argument_types_are_matched_exactly_in_every_method() -> None:
    # One rule everywhere: the declared built-in type, whatever the value (Int32 3 is not a UInt32, and
    # Double 3.0 is a Double like any other); an empty array argument may arrive as a Null variant.
    for args, index in (
        ([Argument(3, "Int32"), d(1.0)], 0),
        ([Argument(3, "Int64"), d(1.0)], 0),
        ([u(3), Argument(3, "Int32")], 1),
        ([u(3), Argument(3.0, "Float")], 1),
    ):
        error = _refused(check_feed_part, FEED, args)
        assert (error.status, error.index) == ("BadTypeMismatch", index), args
    assert check_feed_part(FEED, [u(3), d(3.0)]).timeout == 3.0
    error = _refused(
        check_run_program,
        RUN,
        [
            Argument("{steps: [{field: {type: radial, center: [0, 0]}}]}", "String"),
            Argument(5, "Int32"),
            d(0),
            d(0),
        ],
        "",
    )
    assert (error.status, error.index) == (
        "BadTypeMismatch",
        1,
    ) and "expected a Double, got Int32" in error.message
    error = _refused(check_follow_path, FOLLOW, [Argument([0, 1], "Int32", True), Argument(None, "Null")])
    assert (error.status, error.index) == ("BadTypeMismatch", 0)
    assert check_follow_path(FOLLOW, [Argument([3.0, 0.0], "Double", True), Argument(None, "Null")]).tilt == (
        3.0,
        0.0,
    )


def test_every_physical_variable_has_a_unece_unit_and_counters_have_uint32_twins() -> None:
    assert units.unit_id("MTR") == 5067858 and units.unit_id("C81") == 0x433831  # OPC 10000-8 5.6.4.4
    for kind, counters in layout.COUNTERS.items():
        specs = {v.path: v for v in layout.variables(kind)}
        for spec in specs.values():
            if spec.type in ("Double", "Float"):
                assert spec.unit in units.UNITS, (kind, spec.path)
            else:
                assert not spec.unit, (kind, spec.path)
        for name in counters:
            assert specs[layout.counter_path(name)].type == "UInt64"
            assert specs[layout.counter32_path(name)].type == "UInt32"
        assert specs["Status.CounterValues32"].type == "UInt32"
