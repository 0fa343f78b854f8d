"""Speech: the robot's side of the dialogue with the human teammate.

It turns text into audio and audio into words; it knows nothing of plans.

Modules:
- `languages`: the `Language` table ("en-us", "ko"): espeak-ng voice, gTTS
  language, yes and no phrases, distractor words; `language(code)`.
- `synthesis`: `synthesize(text, language, engine, cache_dir) -> Utterance`,
  gTTS (MP3) when its service answers, else espeak-ng (16 kHz WAV); cached.
- `devices`: `play_local(utterance)` on the local speakers; `NoAudioDevice`.
- `audio`: `Recording`, WAV reading and writing, resampling, RMS level.
- `voice_activity`: the energy gate that tells speech from silence and noise, and
  `EndOfSpeech`, where a live utterance ends (the microphone's cut).
- `models`: `choose_model(language)`: which engine hears it (vosk where a vosk
  model is given and for Korean, pocketsphinx for English); `find_model`,
  `load_model(dir)` (a vosk model, once per process).
- `recognition`: `Recognizer.recognize(samples, rate) -> Heard` (yes / no /
  refused with a reason), the same calls whichever engine hears; `heard`:
  `Heard`, `Meaning`, `Reason`.
- `vosk_recognition`, `sphinx`: the two engines, each with its rejection
  strategy in its docstring (vosk: Korean; pocketsphinx: English, its model
  installed with the wheel).
- `sources`: the `AudioSource` protocol: `MicrophoneSource`,
  `WavFolderSource`, `SimulatedVoice`.
- `evaluation`: the synthetic test set and its score; `bench`: the benchmark.

Flow:
    text -> synthesize -> Utterance (WAV/MP3 file) -> play_local or the page
    AudioSource.listen -> Recording -> Recognizer.recognize
        vosk:         energy gate -> answers grammar (+ n-best margin)
                      -> distractor grammar -> Heard(words, confidence, meaning, reason)
        pocketsphinx: energy gate -> answers grammar -> word score
                      -> phone loop -> coverage -> Heard(...)
"""
