"""The Android build files say what android/README.md promises: modules :core and :app, a pinned
Android Gradle Plugin and Gradle, compileSdk 34, minSdk 26, Java 17, pinned LiteRT artifacts,
org.json left to the platform, and a manifest with both activities (the playback screen as the
launcher) and the OpenGL ES 3.1 requirement.  Nothing here can build the app (no Android SDK on
this machine); these are the facts a reader of the files would check."""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET

from java_harness import REPO

ANDROID = REPO / "android"
APP_SOURCES = ANDROID / "app" / "src" / "main" / "java" / "io" / "mnsskit" / "sample"
NS = "{http://schemas.android.com/apk/res/android}"
PINNED = r"\d+\.\d+\.\d+"


def text(name: str) -> str:
    return (ANDROID / name).read_text()


def setting(build: str, key: str) -> str:
    match = re.search(rf"^\s*{key}\s*[= ]\s*(\S+)\s*$", build, re.M)
    assert match, f"{key} not set"
    return match.group(1)


def test_settings_include_core_and_app():
    settings = text("settings.gradle")
    assert re.search(r'^include\s+":core",\s*":app"\s*$', settings, re.M)
    assert "google()" in settings and "mavenCentral()" in settings


def test_plugin_and_gradle_versions_are_pinned():
    agp = re.search(rf'id "com\.android\.application" version "({PINNED})" apply false', text("build.gradle"))
    assert agp, "the Android Gradle Plugin version must be pinned in android/build.gradle"
    wrapper = text("gradle/wrapper/gradle-wrapper.properties")
    gradle = re.search(r"gradle-(\d+)\.(\d+)(?:\.\d+)?-bin\.zip", wrapper)
    assert gradle and (int(gradle.group(1)), int(gradle.group(2))) >= (8, 7)  # AGP 8.5 needs Gradle 8.7+
    assert agp.group(1).startswith("8.5.")


def test_app_sdk_levels_java_and_dependencies():
    app = text("app/build.gradle")
    assert setting(app, "compileSdk") == "34" and setting(app, "minSdk") == "26"
    assert int(setting(app, "targetSdk")) <= 34
    assert setting(app, "namespace") == '"io.mnsskit.sample"'
    assert app.count("JavaVersion.VERSION_17") == 2
    assert 'implementation project(":core")' in app
    litert = re.findall(r'implementation "com\.google\.ai\.edge\.litert:([\w-]+):([^"]+)"', app)
    assert {name for name, _ in litert} == {"litert", "litert-gpu", "litert-gpu-api"}
    versions = {version for _, version in litert}
    assert len(versions) == 1 and re.fullmatch(PINNED, versions.pop()), "LiteRT artifacts must share one exact version"
    assert "androidx" not in app  # so android.useAndroidX=false is right
    assert re.search(r"^android\.useAndroidX=false$", text("gradle.properties"), re.M)


def test_core_is_plain_java_17_and_leaves_org_json_to_the_platform():
    core = text("core/build.gradle")
    assert 'id "java-library"' in core and core.count("JavaVersion.VERSION_17") == 2
    assert re.search(r'compileOnly "org\.json:json:\d+"', core) and not re.search(r'^\s*implementation "org\.json', core, re.M)


def test_manifest_declares_both_activities_and_gles_3_1():
    root = ET.parse(ANDROID / "app" / "src" / "main" / "AndroidManifest.xml").getroot()
    feature = root.find("uses-feature")
    assert feature.get(f"{NS}glEsVersion") == "0x00030001" and feature.get(f"{NS}required") == "true"
    activities = {a.get(f"{NS}name"): a for a in root.iter("activity")}
    assert set(activities) == {".PlaybackActivity", ".SelfTestActivity"}
    assert all(a.get(f"{NS}exported") == "true" for a in activities.values())  # am start with extras; required with a filter
    launchers = [name for name, a in activities.items()
                 if any(c.get(f"{NS}name") == "android.intent.category.LAUNCHER" for c in a.iter("category"))]
    assert launchers == [".PlaybackActivity"]
    for name in activities:
        source = (APP_SOURCES / f"{name[1:]}.java").read_text()
        assert re.search(rf"public final class {name[1:]} extends Activity\b", source)


def test_readme_commands_name_what_the_build_files_define():
    readme = text("README.md")
    for activity in ("PlaybackActivity", "SelfTestActivity"):
        assert f"io.mnsskit.sample/.{activity}" in readme
    assert "gradle wrapper --gradle-version 8.7" in readme
    assert "/sdcard/Android/data/io.mnsskit.sample/files/bundles/" in readme
    assert "mnss-kit export --sequence" in readme and "--sequence data/test_x2" in readme
